// SPDX-License-Identifier: Apache-2.0
// unit.capi.TheCxxReaderWithoutExceptionsReportsEveryError: kiln/pack_reader.hpp from C++ built with -fno-exceptions
// -fno-rtti, through PackReader's try_ calls. Each error a game can meet comes back as a code and a message instead of
// aborting the program: a missing pack, a manifest changed after the build, one cut short, a blob damaged after the
// build (found at its first use), an unknown pass, keyword, group conflict, missing keyword, a stripped variant, an
// index or id out of range; and the calls that succeed give what the throwing calls give.
// usage: reader_no_exceptions_test <pack dir> <scratch dir>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>

#include "checks.hpp"
#include "kiln/pack_reader.hpp"

namespace {

using kiln::checks::failures;

template <class T>
void check_error(const kiln::PackResult<T>& result, kiln::PackError::Code code, const char* message_part, int line) {
  if (result) {
    std::fprintf(stderr, "line %d: expected an error, got a value\n", line);
    ++failures;
    return;
  }
  if (result.code() != code) {
    std::fprintf(stderr, "line %d: error code %d, expected %d (%s)\n", line, static_cast<int>(result.code()),
                 static_cast<int>(code), result.message().c_str());
    ++failures;
  }
  if (message_part && result.message().find(message_part) == std::string::npos) {
    std::fprintf(stderr, "line %d: message '%s' lacks '%s'\n", line, result.message().c_str(), message_part);
    ++failures;
  }
}
#define CHECK_ERROR(result, code, part) check_error((result), kiln::PackError::Code::code, (part), __LINE__)

std::string read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write(const std::string& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; }

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) return 2;
  const std::string pack_dir = argv[1], scratch = argv[2];
  using kiln::PackReader;

  // Opening.
  {
    auto missing = PackReader::try_open(scratch + "/no-such.manifest.json");
    CHECK_ERROR(missing, Io, "no such file");
    CHECK(missing.file() == scratch + "/no-such.manifest.json");
  }
  auto opened = PackReader::try_open(pack_dir);
  if (!opened) {
    std::fprintf(stderr, "%s: %s\n", opened.file().c_str(), opened.message().c_str());
    return 1;
  }
  PackReader& pack = *opened;
  const std::string manifest_text = read(pack_dir + "/tiny.manifest.json");
  const size_t archive_at = manifest_text.find(".kpack");
  const size_t archive_name_start = manifest_text.rfind('"', archive_at) + 1;
  const std::string archive_name = manifest_text.substr(archive_name_start, archive_at + 6 - archive_name_start);
  const std::string archive = read(pack_dir + "/" + archive_name);
  CHECK(!archive.empty());
  write(scratch + "/" + archive_name, archive);
  const std::string manifest = scratch + "/tiny.manifest.json";
  std::string changed = manifest_text;
  const size_t vert = changed.find("\"Vert\"");
  CHECK(vert != std::string::npos);
  changed[vert + 1] = 'W';  // still JSON: the manifest's own checksum fails
  write(manifest, changed);
  CHECK_ERROR(PackReader::try_open(manifest), Checksum, "checksum");
  write(manifest, manifest_text.substr(0, 100));  // cut short: no checksum to check
  CHECK_ERROR(PackReader::try_open(manifest), Format, "no checksum");

  // A blob damaged after the build: the open succeeds, the blob's first use reports it; the others read as before.
  write(manifest, manifest_text);
  std::string damaged = archive;
  damaged[damaged.size() - 3] ^= 0x40;  // in the last blob
  write(scratch + "/" + archive_name, damaged);
  {
    auto with_damage = PackReader::try_open(manifest);
    CHECK(static_cast<bool>(with_damage));
    CHECK_ERROR(PackReader::try_open(manifest, PackReader::Check::Full), Checksum, nullptr);
    size_t checksum_errors = 0, blobs = 0;
    for (uint32_t id = 0;; ++id, ++blobs) {
      auto blob = with_damage->try_blob(id);
      if (blob) {
        CHECK(*blob == *pack.try_blob(id));
        continue;
      }
      if (blob.code() == kiln::PackError::Code::Checksum) {
        ++checksum_errors;
        continue;
      }
      CHECK_ERROR(blob, Format, "out of range");  // past the last blob
      break;
    }
    CHECK(blobs > 4);
    CHECK(checksum_errors == 1);
  }

  // Selection.
  CHECK_ERROR(pack.try_select("Nope", {}), UnknownPass, "pack 'tiny' has no pass 'Nope'");
  CHECK_ERROR(pack.try_variant_count("Nope"), UnknownPass, "'Nope'");
  CHECK_ERROR(pack.try_keyword_groups("Nope"), UnknownPass, "'Nope'");
  CHECK_ERROR(pack.try_select("Main", {"QUALITY_LOW", "QUALITY_HIGH"}), ConflictingKeywords, "including 'QUALITY_LOW'");
  CHECK_ERROR(pack.try_select("Main", {"FOG"}), MissingKeyword, "needs one of: QUALITY_LOW QUALITY_HIGH");
  CHECK_ERROR(pack.try_select("Main", {"FOG", "TINT", "QUALITY_LOW"}), Stripped, "it was stripped from pack 'tiny'");
  CHECK(static_cast<bool>(pack.try_select("Main", {"QUALITY_LOW", "ALPHA_CLIP"})));  // another pass's keyword
  CHECK_ERROR(pack.try_select("Main", {"QUALITY_LOW", "ALPHA_CLIP"}, true), UnknownKeyword, "'ALPHA_CLIP'");
  auto count = pack.try_variant_count("Main");
  CHECK(count && *count > 0);
  if (count) CHECK_ERROR(pack.try_variant("Main", *count), Format, "out of range");
  CHECK_ERROR(pack.try_reflection(1u << 30), Format, "out of range");

  // What succeeds is what the variant holds.
  auto selected = pack.try_select("Main", {"QUALITY_LOW"});
  CHECK(static_cast<bool>(selected));
  if (selected) {
    auto same = pack.try_variant("Main", selected->index);
    CHECK(same && same->index == selected->index && same->stages.size() == selected->stages.size());
    for (const kiln::StageView& stage : selected->stages) CHECK(!stage.spirv.empty() && !stage.glsl.empty());
  }
  auto groups = pack.try_keyword_groups("Main");
  CHECK(groups && !groups->empty());
  CHECK(static_cast<bool>(pack.try_reflection(0)));

  return kiln::checks::result();
}
