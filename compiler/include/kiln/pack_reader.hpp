// SPDX-License-Identifier: Apache-2.0
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

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kiln/folded_keywords.hpp"
#include "kiln/manifest.hpp"
#include "kiln/result.hpp"

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
  // One member per target, named by its id (kiln/targets.def): spirv, glsl, gles, msl. Bytes; empty if the target
  // was not built.
#define KILN_TARGET(Enumerator, id, ...) std::string_view id;
#include "kiln/targets.def"
  const Reflection* reflection = nullptr;

  // The member of `target`.
  std::string_view code(Target target) const { return const_cast<StageView&>(*this).code(target); }
  std::string_view& code(Target target) {
    switch (target) {
#define KILN_TARGET(Enumerator, id, ...) \
  case Target::Enumerator: return id;
#include "kiln/targets.def"
    }
    return spirv;  // not reached: every Target has its case
  }
};

struct SelectedVariant {
  std::string pass;
  std::vector<std::string> keywords;  // sorted, as stored
  size_t index = 0;                   // within the pass
  std::vector<StageView> stages;
  // The pass's folded keywords (kiln/folded_keywords.hpp), each on or off for this variant: the specialization
  // constants to give the pipeline and the dynamic-branch bools to write into `_KilnKeywords`. Empty when every
  // keyword of the pass chooses a module.
  std::vector<KeywordValue> values;
  const StageView* stage(std::string_view name) const;
};

namespace runtime {
struct Index;
}

// One variant that a pack switch (PackReader::poll_update) touched, matched across the two packs by pass name and
// keyword set. "Same code" is binary identity: per stage the entry point, each target's blob checksum (XXH3-64 of
// its bytes) and the reflection record, and the folded keywords' values; a variant equal in all of them is not
// listed unless its index in the pass moved.
struct VariantChange {
  enum class Kind {
    Added,    // a keyword set the previous pack lacked (select() used to fail with Stripped for it)
    Changed,  // the same keyword set with other code: recreate its pipeline
    Removed,  // a keyword set the new pack lacks (select() now fails with Stripped): drop its pipeline
    Moved,    // the same code at another index of its pass: keep the pipeline, re-key it if you key by index
  };
  static constexpr size_t kNoIndex = SIZE_MAX;
  Kind kind = Kind::Changed;
  std::string pass;
  std::vector<std::string> keywords;  // sorted, as stored
  size_t old_index = kNoIndex;        // SelectedVariant::index in the previous pack; kNoIndex when Added
  size_t new_index = kNoIndex;        // SelectedVariant::index in the new pack; kNoIndex when Removed
};

// What PackReader::poll_update() found.
struct PackUpdate {
  bool switched = false;   // the reader now serves a newer pack; false: nothing new (or the same archive again)
  uint64_t version = 1;    // the pack version served after this poll: 1 as opened, one more per switch
  std::string archive;     // the archive served after this poll, "<name>.<xxh3>.kpack"
  bool ids_changed = false;  // passes or keywords were added, removed or reordered: the C API's kiln_pass and
                             // kiln_keyword ids of the previous pack do not carry over
  std::vector<VariantChange> changes;  // by pass (the new pack's order, then the passes it dropped), then keywords
};

// What a PackReader::try_ call gives code built without exceptions (-fno-exceptions, as many games are): kiln's
// Result (kiln/result.hpp) of the value or the PackError that would have been thrown, with the error's code,
// message and file at hand. Test it before using the value.
template <class T>
class PackResult : public Result<T, PackError> {
 public:
  PackResult(T value) : Result<T, PackError>(std::move(value)) {}  // NOLINT(google-explicit-constructor): a result is its value
  PackResult(PackError::Code code, const std::string& message, std::string file)
      : Result<T, PackError>(failure(PackError(code, message, std::move(file)))) {}
  // The error, when there is no value.
  PackError::Code code() const noexcept { return this->error().code(); }
  std::string message() const { return this->error().what(); }
  const std::string& file() const noexcept { return this->error().file(); }
};

class PackReader {
  struct Live;  // the reader: the version served now, retired versions, usage recording, poll_update's state

 public:
  // What open() checks before it returns.
  enum class Check {
    // What a game needs, in about a millisecond: the manifest's checksum and head, the archive's header, blob table
    // and runtime index. Each blob's checksum is checked when the blob is first used (blob(), variant(), select()),
    // and the archive's pages that are never used are never read.
    OnUse,
    // Everything, now: the whole archive's checksum, every blob, the manifest parsed and the runtime index equal to
    // the one its records give. For tools (kiln inspect, diff-packs, extract, lint, the remote cache).
    Full,
  };

  // `path` is a manifest file or a directory holding exactly one manifest. Every failure is a PackError: sizes and
  // checksums are checked before anything is parsed, and running out of memory is Code::OutOfMemory. The files are
  // mapped, not copied: a pack's files must not be truncated or rewritten in place while it is open (kiln never
  // does: a build replaces them by rename).
  static PackReader open(const std::filesystem::path& path, Check check = Check::OnUse);

  PackReader(PackReader&&) noexcept;
  PackReader& operator=(PackReader&&) noexcept;
  ~PackReader();

  const std::string& name() const { return name_; }
  // The whole manifest, for tools. After an OnUse open it is parsed on the first call (tens of milliseconds for
  // the default pack) and may throw PackError; selection never needs it.
  const Manifest& manifest() const;
  std::vector<std::string> passes() const;
  size_t variant_count(std::string_view pass) const;
  // Keywords declared by the pass, by group.
  std::vector<std::vector<std::string>> keyword_groups(std::string_view pass) const;

  SelectedVariant select(std::string_view pass, const std::vector<std::string>& keywords, bool strict = false) const;
  SelectedVariant variant(std::string_view pass, size_t index) const;
  // A blob's bytes, checked (and decompressed) on first use; they live as long as the reader, or after a pack switch
  // until the next poll_update() call (see there).
  std::string_view blob(uint32_t id) const;
  // A reflection record, decoded on first use.
  const Reflection& reflection(uint32_t id) const;
  // The runtime index (kiln/runtime_index.hpp, internal): the C API's tables are built from it.
  const runtime::Index& index() const;

  // Usage recording (docs/usage.md): from this call on, every select() is counted in a usage log, written to
  // `file` (atomically) by flush_usage() and when the reader goes. A variant served costs one relaxed atomic
  // increment; a keyword set the pack lacks (Stripped) is kept with the nearest variant the error names, at most
  // `max_missing` distinct sets (more are counted in the log's "missing_dropped"). Thread-safe; calling it again
  // changes the file and the tags and keeps the counts. The log's format is variants/schema/usage.schema.json.
  struct UsageOptions {
    std::filesystem::path file;
    std::vector<std::pair<std::string, std::string>> tags;  // the game's labels: {"scene", "forest"}, {"build", "1.4"}
    size_t max_missing = 4096;
  };
  void record_usage(UsageOptions options);
  // Writes the log now: the number of distinct keyword sets in it, or the error (Code::Io). Nothing to write (no
  // recording): 0.
  PackResult<size_t> flush_usage() const noexcept;
  // For the C API's selection by ids, which does not go through select(): counts variant `variant` of pass `pass`
  // (their indices in the index) as served, when recording.
  void note_selected(uint32_t pass, uint32_t variant) const noexcept;

  // Live updates (docs/reader.md, "Live updates"). Looks at the manifest this reader opened: when a build has
  // replaced it (kiln renames the new archive, then the new manifest, into place), opens the new pack with the checks
  // open() makes, switches every later call to it at once and says which variants changed, so that a renderer
  // recreates only their pipelines. Nothing new costs one stat() of the manifest. A damaged or incomplete new pack
  // is refused with its PackError (reported once: later polls say nothing new until its files change again), and
  // the previous pack keeps serving. Thread-safe, also against select() and the other calls running at the same
  // time: each call sees one pack, whole, and select() stays lock-free (it pins the pack it uses with one atomic
  // increment on the calling thread's own cache line).
  //
  // Ownership across a switch: SelectedVariant's strings and indices are the caller's. The views into the pack
  // (StageView code bytes and reflection; what blob(), reflection(), manifest() and index() return) belong to the
  // pack version they came from, which a switch retires: it stays mapped until the next poll_update() call after the
  // switch, and while any select() still running in it or any Pin (below) taken before the switch lives. So poll once
  // per frame, where the last frame's use of those views is done (or have the threads that use them hold a Pin);
  // recreate what `changes` lists from the new pack (select() again, or variant() with new_index), and fetch again
  // any view you keep (a reflection pointer) before the next poll. Indices given to variant() are always the
  // current pack's. Usage recording (record_usage) carries over: the log counts each keyword set's selections from
  // every pack version served.
  PackResult<PackUpdate> poll_update() noexcept;
  // For threads that use views while another thread may poll: while a Pin lives, no pack version that the calls of
  // any thread may see is freed, so the views of every select() made after the Pin was taken stay valid until it goes.
  // Take one per frame or job (it costs what select() pays to pin: one atomic increment on the thread's own cache
  // line); poll_update() never waits for it, it frees the versions it replaced after the last such Pin is gone. A
  // Pin held for hours keeps every version replaced meanwhile in memory.
  class Pin {
   public:
    Pin(Pin&& other) noexcept;
    Pin& operator=(Pin&&) = delete;
    ~Pin();

   private:
    friend class PackReader;
    explicit Pin(Live* live) noexcept;
    Live* live_ = nullptr;
    uint32_t stripe_ = 0, parity_ = 0;
  };
  [[nodiscard]] Pin pin() const noexcept;
  // A file descriptor (inotify, non-blocking) that becomes readable when a file in the pack's directory is
  // replaced: put it in the game's poll set and call poll_update() when it is; poll_update() drains it. Owned by the
  // reader (closed with it); the same one on every call. Code::Io when inotify is not available.
  PackResult<int> update_fd() noexcept;

  // The calls above that can fail, for code built without exceptions: each returns its PackError instead of
  // throwing it (running out of memory included: Code::OutOfMemory). A reader from try_open() serves every call.
  static PackResult<PackReader> try_open(const std::filesystem::path& path, Check check = Check::OnUse) noexcept;
  PackResult<SelectedVariant> try_select(std::string_view pass, const std::vector<std::string>& keywords,
                                         bool strict = false) const noexcept;
  PackResult<SelectedVariant> try_variant(std::string_view pass, size_t index) const noexcept;
  PackResult<size_t> try_variant_count(std::string_view pass) const noexcept;
  PackResult<std::vector<std::vector<std::string>>> try_keyword_groups(std::string_view pass) const noexcept;
  PackResult<std::string_view> try_blob(uint32_t id) const noexcept;
  PackResult<const Reflection*> try_reflection(uint32_t id) const noexcept;

 private:
  struct State;  // one pack version: its files, index and caches
  PackReader();
  static PackReader open_checked(const std::filesystem::path& path, Check check);  // open() less its std::bad_alloc guard
  static std::unique_ptr<State> load(const std::filesystem::path& manifest_file, Check check, std::string* archive_path = nullptr);
  uint32_t find_pass(const State& state, std::string_view name) const;
  SelectedVariant variant_of(State& state, uint32_t pass, uint32_t index) const;
  SelectedVariant select_in(State& state, std::string_view pass, const std::vector<std::string>& keywords, bool strict) const;
  static std::string_view blob_of(State& state, uint32_t id);
  static const Reflection& reflection_of(State& state, uint32_t id);

  std::string name_;
  std::unique_ptr<Live> live_;
};

}  // namespace kiln
