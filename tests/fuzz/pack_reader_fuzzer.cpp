// SPDX-License-Identifier: Apache-2.0
// libFuzzer harness: kiln::PackReader over a fuzzed manifest and archive. Every outcome but a PackError is a
// finding: another exception escapes and aborts, and ASan/UBSan report memory errors and undefined behaviour.
//
// Input: 1 byte of flags, a 4-byte little-endian manifest length, the manifest's bytes, the archive's bytes.
// Random bytes rarely get past a checksum, so unless a flag bit says otherwise the harness reseals what it
// was given, by the rules in kiln/pack_format.hpp (not with kiln's writer): bit 0 set keeps the archive
// header's checksums (the whole archive's, the blob table's and runtime index's) and size as they are, bit 1 the manifest's record of the archive (file name, size,
// XXH3-64), bit 2 the manifest's own checksum, bit 3 the blob table's checksums of blobs stored as they are
// (stored size = raw size, so a mutated table reaches that path too). Resealing edits the manifest's text in
// place, so the fuzzer still controls every byte of the JSON around it.
#include <xxhash.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "kiln/pack_format.hpp"
#include "kiln/pack_reader.hpp"
#include "kiln/manifest_json.hpp"

namespace {

std::string hex64(uint64_t value) {
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(value));
  return text;
}

// Replaces the characters of a JSON string value that starts at `at` (just after its opening quote), up to its
// closing quote, with `value`. Returns where the value ends, or npos when the string does not close.
size_t replace_string_value(std::string& text, size_t at, const std::string& value) {
  const size_t close = text.find('"', at);
  if (close == std::string::npos) return close;
  text.replace(at, close - at, value);
  return at + value.size();
}

uint64_t get64(const std::string& bytes, size_t at) {
  uint64_t value = 0;
  for (int i = 0; i < 8; ++i) value |= static_cast<uint64_t>(static_cast<unsigned char>(bytes[at + i])) << (8 * i);
  return value;
}

struct Resealed {
  std::string manifest;
  std::string archive_file;  // as the manifest names it after resealing; empty when it names none
};

Resealed reseal(std::string manifest, std::string& archive, uint8_t flags) {
  auto put64 = [&](size_t at, uint64_t value) {
    for (int i = 0; i < 8; ++i) archive[at + i] = static_cast<char>(value >> (8 * i));
  };
  if (!(flags & 8) && archive.size() >= kiln::kPackHeaderSize) {
    uint32_t count = 0;
    for (int i = 0; i < 4; ++i) count |= static_cast<uint32_t>(static_cast<unsigned char>(archive[12 + i])) << (8 * i);
    for (uint64_t entry = kiln::kPackHeaderSize, i = 0; i < count && entry + kiln::kPackBlobEntrySize <= archive.size();
         ++i, entry += kiln::kPackBlobEntrySize) {
      const uint64_t offset = get64(archive, entry), stored = get64(archive, entry + 8);
      if (stored == get64(archive, entry + 16) && offset <= archive.size() && stored <= archive.size() - offset)
        put64(entry + 24, XXH3_64bits(archive.data() + offset, stored));
    }
  }
  if (!(flags & 1) && archive.size() >= kiln::kPackHeaderSize) {
    put64(24, archive.size());
    // The head (blob table and runtime index) ends where the header says the index ends.
    const uint64_t head_end = get64(archive, 32) + get64(archive, 40);
    if (head_end >= kiln::kPackHeaderSize && head_end <= archive.size())
      put64(48, XXH3_64bits(archive.data() + kiln::kPackHeaderSize, head_end - kiln::kPackHeaderSize));
    put64(16, XXH3_64bits(archive.data() + kiln::kPackHeaderSize, archive.size() - kiln::kPackHeaderSize));
  }
  const std::string archive_hash = hex64(XXH3_64bits(archive.data(), archive.size()));
  Resealed out;
  const size_t record = manifest.find("\"archive\":");
  if (record != std::string::npos) {
    const std::string file_key = "\"file\": \"", size_key = "\"size\": ", hash_key = "\"xxh3_64\": \"";
    if (size_t file = manifest.find(file_key, record); file != std::string::npos) {
      const size_t start = file + file_key.size(), close = manifest.find('"', start);
      if (close != std::string::npos) {
        std::string name = manifest.substr(start, close - start);
        // <anything>.<16 hex>.kpack keeps its <anything> and takes the archive's hash.
        const size_t tail = 1 + 16 + kiln::kArchiveExtension.size();
        if (!(flags & 2) && name.size() > tail && name.ends_with(kiln::kArchiveExtension) &&
            name[name.size() - tail] == '.') {
          name.replace(name.size() - tail + 1, 16, archive_hash);
          replace_string_value(manifest, start, name);
        }
        out.archive_file = name;
      }
    }
    if (!(flags & 2)) {
      if (size_t size = manifest.find(size_key, record); size != std::string::npos) {
        const size_t start = size + size_key.size();
        const size_t end = manifest.find_first_not_of("0123456789", start);
        manifest.replace(start, (end == std::string::npos ? manifest.size() : end) - start,
                         std::to_string(archive.size()));
      }
      if (size_t hash = manifest.find(hash_key, record); hash != std::string::npos)
        replace_string_value(manifest, hash + hash_key.size(), archive_hash);
    }
  }
  const size_t checksum = manifest.find(kiln::kManifestChecksumField);
  const size_t digits = checksum + std::strlen(kiln::kManifestChecksumField);
  if (!(flags & 4) && checksum != std::string::npos && manifest.size() >= digits + kiln::kManifestChecksumDigits) {
    manifest.replace(digits, kiln::kManifestChecksumDigits, kiln::kManifestChecksumDigits, '0');
    manifest.replace(digits, kiln::kManifestChecksumDigits, hex64(XXH3_64bits(manifest.data(), manifest.size())));
  }
  out.manifest = std::move(manifest);
  return out;
}

// A name the harness may create in its directory: the reader must refuse any other (tested there), and the
// harness must not write outside its directory whatever the input says.
bool plain_file_name(const std::string& name) {
  return !name.empty() && name.size() < 200 && name != "." && name != ".." &&
         name.find_first_of(std::string_view("/\0", 2)) == std::string::npos;
}

void write(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// Everything a game does with a pack: list passes, select and read variants (which decompresses blobs).
void use(const kiln::PackReader& pack) {
  size_t touched = 0;
  for (const std::string& pass : pack.passes()) {
    auto try_select = [&](const std::vector<std::string>& keywords, bool strict) {
      try {
        for (const kiln::StageView& stage : pack.select(pass, keywords, strict).stages)
          touched += stage.spirv.size() + stage.glsl.size() + stage.gles.size() + stage.msl.size();
      } catch (const kiln::PackError&) {
      }
    };
    const size_t count = pack.variant_count(pass);
    for (size_t i = 0; i < count && i < 64; ++i) {
      try {
        kiln::SelectedVariant v = pack.variant(pass, i);
        for (const kiln::StageView& stage : v.stages) {
          touched += stage.spirv.size() + stage.glsl.size() + stage.gles.size() + stage.msl.size();
          if (!stage.reflection) std::abort();  // the reader promises a reflection for every stage
        }
        try_select(v.keywords, true);
      } catch (const kiln::PackError&) {
      }
    }
    std::vector<std::string> first_of_each;
    for (const auto& group : pack.keyword_groups(pass))
      if (!group.empty()) first_of_each.push_back(group.back());
    try_select(first_of_each, false);
    try_select({}, false);
  }
  for (uint32_t id = 0; id < 64; ++id) {
    try {
      touched += pack.blob(id).size();
    } catch (const kiln::PackError&) {
    }
  }
  if (touched == SIZE_MAX) std::abort();  // keeps the reads
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::filesystem::path directory = [] {
    std::string pattern = (std::filesystem::temp_directory_path() / "kiln-fuzz-pack-XXXXXX").string();
    if (!::mkdtemp(pattern.data())) std::abort();
    return std::filesystem::path(pattern);
  }();
  // Registered once `directory` exists, so that it runs before `directory` is destroyed.
  static const bool cleanup = std::atexit([] {
    std::error_code ec;
    std::filesystem::remove_all(directory, ec);
  }) == 0;
  (void)cleanup;
  if (size < 5) return 0;
  const uint8_t flags = data[0];
  uint32_t manifest_size = 0;
  for (int i = 0; i < 4; ++i) manifest_size |= static_cast<uint32_t>(data[1 + i]) << (8 * i);
  const std::string_view rest(reinterpret_cast<const char*>(data) + 5, size - 5);
  manifest_size = static_cast<uint32_t>(std::min<size_t>(manifest_size, rest.size()));
  std::string archive(rest.substr(manifest_size));
  Resealed pack = reseal(std::string(rest.substr(0, manifest_size)), archive, flags);

  std::error_code ec;
  std::filesystem::remove_all(directory, ec);
  std::filesystem::create_directory(directory, ec);
  const std::filesystem::path manifest = directory / "fuzz.manifest.json";
  write(manifest, pack.manifest);
  if (plain_file_name(pack.archive_file) && directory / pack.archive_file != manifest)
    write(directory / pack.archive_file, archive);
  // A game's open (the runtime index; blobs and reflections on first use), then a tool's (everything, the manifest
  // parsed and compared with the index).
  for (kiln::PackReader::Check check : {kiln::PackReader::Check::OnUse, kiln::PackReader::Check::Full}) {
    try {
      kiln::PackReader reader = kiln::PackReader::open(manifest, check);
      use(reader);
      if (check == kiln::PackReader::Check::OnUse) (void)reader.manifest().passes.size();
    } catch (const kiln::PackError& e) {
      // KILN_FUZZ_PRINT=1 shows how far each input got, to check that resealing lets inputs past the checksums.
      static const bool print = std::getenv("KILN_FUZZ_PRINT") != nullptr;
      if (print) std::fprintf(stderr, "PackError: %s\n", e.what());
    }
  }
  return 0;
}
