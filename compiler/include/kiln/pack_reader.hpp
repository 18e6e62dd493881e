// Runtime reader for kiln variant packs: loads `<name>.manifest.json` and the archive it names
// (`<name>.<XXH3-64>.kpack`), checks the format version and every checksum, and selects the variant for a
// keyword set.
//
// Selection rule (no silent "closest match"):
//   * Keywords that the pass does not declare are ignored (they are global keywords meant for other
//     passes), unless `strict` is set, in which case they are an error.
//   * Two keywords of one group are an error. A group with no keyword given takes its "_" (off)
//     value; a group without "_" needs one of its keywords.
//   * If the resulting combination was stripped from the pack (constraints, scenes, budget), select
//     throws PackError::Code::Stripped naming the requested keywords that no variant of the pass
//     combines that way, and the nearest variants that do exist.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "kiln/manifest.hpp"

namespace kiln {

class PackError : public std::runtime_error {
 public:
  enum class Code {
    Io, Format, Version, Checksum, UnknownPass, UnknownKeyword, ConflictingKeywords, MissingKeyword, Stripped,
    OutOfMemory  // open(): the pack does not fit in the memory (or address space) the process has
  };
  PackError(Code code, const std::string& message, std::string file = {})
      : std::runtime_error(message), code_(code), file_(std::move(file)) {}
  Code code() const { return code_; }
  // The file the error is in ("dir/p.manifest.json:12:5" when the line and column are known, "dir/p.<xxh3>.kpack"),
  // for `file: error: message`; empty when it is about the request, not a file (UnknownPass, Stripped...).
  const std::string& file() const { return file_; }

 private:
  Code code_;
  std::string file_;
};

struct StageView {
  std::string stage;        // "vertex", "fragment"
  std::string entry_point;  // as compiled
  std::string_view spirv;   // bytes; empty if the target was not built
  std::string_view glsl;
  std::string_view gles;
  std::string_view msl;
  const Reflection* reflection = nullptr;
};

struct SelectedVariant {
  std::string pass;
  std::vector<std::string> keywords;  // sorted, as stored
  size_t index = 0;                   // within the pass
  std::vector<StageView> stages;
  const StageView* stage(std::string_view name) const;
};

class PackReader {
 public:
  // `path` is a manifest file or a directory holding exactly one manifest. Every failure is a PackError: sizes and
  // checksums are checked before anything is parsed, and running out of memory is Code::OutOfMemory.
  static PackReader open(const std::filesystem::path& path);

  const std::string& name() const { return name_; }
  const Manifest& manifest() const { return manifest_; }
  std::vector<std::string> passes() const;
  size_t variant_count(std::string_view pass) const;
  // Keywords declared by the pass, by group.
  std::vector<std::vector<std::string>> keyword_groups(std::string_view pass) const;

  SelectedVariant select(std::string_view pass, const std::vector<std::string>& keywords, bool strict = false) const;
  SelectedVariant variant(std::string_view pass, size_t index) const;
  std::string_view blob(uint32_t id) const;

 private:
  struct Pass {
    const ManifestPass* manifest = nullptr;
    std::vector<std::vector<std::string>> groups;  // "" is the off value
    std::map<std::string, size_t> by_key;          // joined sorted keywords -> variant index
  };
  const Pass& find_pass(std::string_view name) const;
  static PackReader open_checked(const std::filesystem::path& path);  // open() less its std::bad_alloc guard

  struct Blob {
    uint64_t offset = 0;
    uint64_t stored_size = 0;
    uint64_t raw_size = 0;
    uint64_t hash = 0;  // XXH3-64 of the raw bytes
  };
  std::string name_;
  Manifest manifest_;
  std::string archive_;
  std::string archive_file_;  // its path, for errors found when a blob is first decompressed
  std::vector<Blob> blobs_;
  // Compressed blobs are decompressed on first use and kept; the reader may be shared between threads.
  std::unique_ptr<std::mutex> decompress_mutex_ = std::make_unique<std::mutex>();
  mutable std::map<uint32_t, std::unique_ptr<std::string>> decompressed_;
  std::map<std::string, Pass, std::less<>> passes_;
};

}  // namespace kiln
