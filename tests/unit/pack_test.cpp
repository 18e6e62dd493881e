// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <functional>
#include <future>
#include <random>

#include "kiln/pack_format.hpp"
#include "kiln/pack_reader.hpp"
#include "kiln/manifest_json.hpp"
#include "common/files.hpp"
#include "kiln/runtime_index.hpp"
#include "pack/pack_writer.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

using nlohmann::json;

const std::string kCompressedMsl = [] {
  std::string text;
  for (int i = 0; i < 64; ++i) text += "float3 light" + std::to_string(i) + " = normalize(L - P);\n";
  return text;
}();

// A hand-made pack: pass P with groups {_, A, B} and {_, C}; the variant [B C] is stripped.
std::filesystem::path write_sample_pack(const testing::TempDir& dir) {
  ArchiveBuilder archive;
  uint32_t spv = archive.add("SPIRV-BYTES");
  uint32_t same = archive.add("SPIRV-BYTES");
  EXPECT_EQ(spv, same);  // deduplicated
  uint32_t glsl = archive.add("#version 450\n");
  uint32_t msl = archive.add(kCompressedMsl);  // stored as a zstd frame
  Manifest manifest;
  manifest.format_version = kPackFormatVersion;
  manifest.name = "sample";
  manifest.binaries.push_back({Stage::Fragment, "F", {{Target::Spirv, spv}, {Target::Glsl, glsl}, {Target::Msl, msl}}, 0});
  manifest.reflections.emplace_back();
  ManifestPass& pass = manifest.passes.emplace_back();
  pass.name = "P";
  pass.entry_points[Stage::Fragment] = "F";
  pass.keyword_groups = {{"multi_compile", {"", "A", "B"}, kAllStageBits}, {"multi_compile", {"", "C"}, kAllStageBits}};
  for (auto keywords : std::vector<std::vector<std::string>>{{}, {"A"}, {"B"}, {"C"}, {"A", "C"}})
    pass.variants.push_back({keywords, {{Stage::Fragment, 0}}});
  EXPECT_TRUE(write_pack(dir.path(), "sample", archive, manifest));
  return dir / "sample.manifest.json";
}

uint64_t get64(const std::string& bytes, size_t at) {
  uint64_t value = 0;
  for (int i = 0; i < 8; ++i) value |= static_cast<uint64_t>(static_cast<unsigned char>(bytes[at + i])) << (8 * i);
  return value;
}
void set64(std::string& bytes, size_t at, uint64_t value) {
  for (int i = 0; i < 8; ++i) bytes[at + i] = static_cast<char>(value >> (8 * i));
}

// The blob table entry of the sample pack's one zstd frame (the MSL).
size_t compressed_entry(const std::string& archive) {
  for (size_t at = kPackHeaderSize; at < kPackHeaderSize + kPackBlobEntrySize * 3; at += kPackBlobEntrySize)
    if (get64(archive, at + 8) < get64(archive, at + 16)) return at;
  ADD_FAILURE() << "the sample pack has no compressed blob";
  return kPackHeaderSize;
}

TEST(Pack, ReaderLoadsWhatTheWriterWroteAndSelectsByKeywords) {
  testing::TempDir dir;
  PackReader pack = PackReader::open(write_sample_pack(dir));
  EXPECT_EQ(pack.name(), "sample");
  SelectedVariant v = pack.select("P", {"C", "A"});
  EXPECT_EQ(v.keywords, (std::vector<std::string>{"A", "C"}));
  ASSERT_NE(v.stage("fragment"), nullptr);
  EXPECT_EQ(v.stage("fragment")->spirv, "SPIRV-BYTES");
  EXPECT_EQ(v.stage("fragment")->glsl, "#version 450\n");
  EXPECT_EQ(v.stage("fragment")->msl, kCompressedMsl);
}

TEST(Pack, KeywordsThePassDoesNotDeclareAreIgnoredUnlessStrict) {
  testing::TempDir dir;
  PackReader pack = PackReader::open(write_sample_pack(dir));
  EXPECT_EQ(pack.select("P", {"A", "GLOBAL_OTHER"}).keywords, (std::vector<std::string>{"A"}));
  try {
    pack.select("P", {"A", "GLOBAL_OTHER"}, true);
    FAIL() << "strict selection accepted an undeclared keyword";
  } catch (const PackError& e) {
    EXPECT_EQ(e.code(), PackError::Code::UnknownKeyword);
  }
}

TEST(Pack, TwoKeywordsOfOneGroupAreAnError) {
  testing::TempDir dir;
  PackReader pack = PackReader::open(write_sample_pack(dir));
  try {
    pack.select("P", {"A", "B"});
    FAIL();
  } catch (const PackError& e) {
    EXPECT_EQ(e.code(), PackError::Code::ConflictingKeywords);
  }
}

TEST(Pack, StrippedCombinationIsAnErrorNamingTheNearestVariants) {
  testing::TempDir dir;
  PackReader pack = PackReader::open(write_sample_pack(dir));
  try {
    pack.select("P", {"B", "C"});
    FAIL();
  } catch (const PackError& e) {
    EXPECT_EQ(e.code(), PackError::Code::Stripped);
    std::string message = e.what();
    EXPECT_NE(message.find("has no variant [B C]"), std::string::npos) << message;
    EXPECT_NE(message.find("nearest variants"), std::string::npos) << message;
  }
}

// A damaged blob: a game's open (Check::OnUse) does not read it, and the first use of it is a checksum error; a
// tool's open (Check::Full) refuses the pack at once. Either way the error names the archive.
TEST(Pack, CorruptedArchiveFailsItsChecksumAtOpenForToolsAndAtFirstUseForGames) {
  testing::TempDir dir;
  auto manifest = write_sample_pack(dir);
  const std::filesystem::path archive = testing::archive_named_by(manifest);
  std::string bytes = testing::read_file(archive);
  bytes[bytes.size() - 3] ^= 0x40;  // in the last blob, the MSL frame
  std::ofstream(archive, std::ios::binary) << bytes;
  auto expect_checksum_error = [&](const std::function<void()>& read, const char* what) {
    try {
      read();
      ADD_FAILURE() << what << ": no error";
    } catch (const PackError& e) {
      EXPECT_EQ(e.code(), PackError::Code::Checksum) << what << ": " << e.what();
      EXPECT_EQ(e.file(), archive.string()) << what;  // the file at fault, for `file: error:`
    }
  };
  expect_checksum_error([&] { PackReader::open(manifest, PackReader::Check::Full); }, "a full open");
  PackReader pack = PackReader::open(manifest);
  EXPECT_EQ(pack.blob(0), "SPIRV-BYTES");  // the blobs that are whole read as they are
  EXPECT_EQ(pack.blob(1), "#version 450\n");
  expect_checksum_error([&] { pack.blob(2); }, "the damaged blob");
  expect_checksum_error([&] { pack.select("P", {"A"}); }, "a variant that uses it");
}

// The blobs a game never uses are never read: a pack whose unused blob is unreadable (here: overwritten with bytes
// that fail every check) opens and serves every other blob, with no error.
TEST(Pack, AnOpenReadsTheArchivesHeadOnly) {
  testing::TempDir dir;
  auto manifest = write_sample_pack(dir);
  std::string archive = testing::read_archive(manifest);
  const size_t entry = compressed_entry(archive);
  const uint64_t offset = get64(archive, entry), stored = get64(archive, entry + 8);
  for (uint64_t i = 0; i < stored; ++i) archive[offset + i] = 'x';  // no zstd frame
  testing::reseal_pack(manifest, archive);
  PackReader pack = PackReader::open(manifest);
  EXPECT_EQ(pack.blob(0), "SPIRV-BYTES");
  EXPECT_THROW(pack.blob(2), PackError);
  EXPECT_THROW(PackReader::open(manifest, PackReader::Check::Full), PackError);
}

// A pack an older kiln wrote (format version 3: no runtime index) is refused with what to do about it.
TEST(Pack, APackOfAnOlderFormatIsRefusedWithRebuildIt) {
  testing::TempDir dir;
  auto manifest = write_sample_pack(dir);
  std::string text = testing::read_file(manifest);
  const std::string current = "\"format_version\": " + std::to_string(kPackFormatVersion) + ",";
  ASSERT_NE(text.find(current), std::string::npos);
  text.replace(text.find(current), current.size(), "\"format_version\": 3,");
  dir.write("sample.manifest.json", testing::resealed_manifest(text));
  for (PackReader::Check check : {PackReader::Check::OnUse, PackReader::Check::Full}) {
    try {
      PackReader::open(manifest, check);
      ADD_FAILURE() << "opened";
    } catch (const PackError& e) {
      EXPECT_EQ(e.code(), PackError::Code::Version);
      EXPECT_EQ(std::string(e.what()), "pack format version 3 is not supported (this reader reads version " +
                                           std::to_string(kPackFormatVersion) + "): rebuild the pack with this version of kiln");
    }
  }
}

// The runtime index is the manifest's records in another form: a full open checks that they agree, so an index that
// a hostile writer made differ from the manifest (both sealed) is refused by tools.
TEST(Pack, AFullOpenChecksThatTheIndexIsTheManifests) {
  testing::TempDir dir;
  auto manifest = write_sample_pack(dir);
  json m = json::parse(testing::read_file(manifest));
  m["passes"][0]["variants"][1]["keywords"] = {"B"};  // the index still says [A]
  dir.write("sample.manifest.json", testing::resealed_manifest(m.dump(1) + "\n"));
  EXPECT_EQ(PackReader::open(manifest).variant("P", 1).keywords, (std::vector<std::string>{"A"}));  // a game reads the index
  try {
    PackReader::open(manifest, PackReader::Check::Full);
    FAIL() << "opened";
  } catch (const PackError& e) {
    EXPECT_EQ(e.code(), PackError::Code::Format);
    EXPECT_EQ(std::string(e.what()), "archive of pack 'sample': its runtime index does not match the manifest");
  }
}

TEST(Pack, TruncatedArchiveIsRejected) {
  testing::TempDir dir;
  auto manifest = write_sample_pack(dir);
  const std::filesystem::path archive = testing::archive_named_by(manifest);
  std::string bytes = testing::read_file(archive);
  std::ofstream(archive, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  EXPECT_THROW(PackReader::open(manifest), PackError);
}

TEST(Pack, NewerFormatVersionIsRefused) {
  testing::TempDir dir;
  auto manifest = write_sample_pack(dir);
  json m = json::parse(testing::read_file(manifest));
  m["format_version"] = kPackFormatVersion + 1;
  dir.write("sample.manifest.json", testing::resealed_manifest(m.dump(1)));  // a newer kiln seals what it writes
  try {
    PackReader::open(manifest);
    FAIL();
  } catch (const PackError& e) {
    EXPECT_EQ(e.code(), PackError::Code::Version);
    EXPECT_EQ(e.file(), manifest.string());
  }
}

// Every byte of the manifest counts: a flipped bit anywhere, even where the JSON stays valid (a blob id, a
// keyword), makes open() fail with a PackError.
TEST(Pack, AnyChangedByteOfTheManifestIsRefused) {
  testing::TempDir dir;
  auto manifest = write_sample_pack(dir);
  const std::string text = testing::read_file(manifest);
  std::mt19937 random(2026);
  for (int trial = 0; trial < 400; ++trial) {
    std::string damaged = text;
    const size_t at = random() % damaged.size();
    damaged[at] = static_cast<char>(damaged[at] ^ (1 << (random() % 8)));
    dir.write("sample.manifest.json", damaged);
    EXPECT_THROW(PackReader::open(manifest), PackError) << "byte " << at << " of\n" << damaged;
  }
}

void every_value_below(const json& value, const json::json_pointer& at, std::vector<json::json_pointer>& out) {
  out.push_back(at);
  if (value.is_object())
    for (const auto& [key, child] : value.items()) every_value_below(child, at / key, out);
  if (value.is_array())
    for (size_t i = 0; i < value.size(); ++i) every_value_below(value[i], at / i, out);
}

// A manifest whose checksum is right but whose content is not what kiln writes (a foreign tool, a bug):
// open(), variant() and select() fail with PackError only, never with a JSON exception or a wild index.
TEST(Pack, WrongManifestContentFailsWithPackErrorOnly) {
  testing::TempDir dir;
  auto manifest = write_sample_pack(dir);
  const json original = json::parse(testing::read_file(manifest));
  std::vector<json::json_pointer> places;
  every_value_below(original, json::json_pointer(), places);
  const json replacements[] = {nullptr, -1, 0, 1, 7, 4294967296.0, "A", "_", json::array(), json::object(), true};
  std::mt19937 random(7);
  size_t opened = 0, refused = 0;
  for (int trial = 0; trial < 600; ++trial) {
    const json::json_pointer& at = places[random() % places.size()];
    if (at.empty() || at.to_string().starts_with("/manifest_xxh3_64")) continue;
    json changed = original;
    const size_t how = random() % (std::size(replacements) + 1);
    if (how == std::size(replacements)) {  // remove it
      json& parent = changed[at.parent_pointer()];
      if (parent.is_object()) parent.erase(at.back());
      else parent.erase(std::stoul(at.back()));
    } else {
      changed[at] = replacements[how];
    }
    dir.write("sample.manifest.json", testing::resealed_manifest(changed.dump(1) + "\n"));
    const std::string what = at.to_string() + " <- " + (how < std::size(replacements) ? replacements[how].dump() : "(removed)");
    try {
      // A tool's open parses the manifest: its content must be what kiln writes. A game's reads the head only.
      PackReader::open(manifest, PackReader::Check::Full);
      PackReader pack = PackReader::open(manifest);
      ++opened;
      for (const std::string& pass : pack.passes()) {
        for (size_t i = 0; i < pack.variant_count(pass); ++i) {
          try {
            SelectedVariant v = pack.variant(pass, i);
            for (const StageView& stage : v.stages) EXPECT_NE(stage.reflection, nullptr);
            pack.select(pass, v.keywords);
          } catch (const PackError&) {
          }
        }
        try {
          pack.select(pass, {"A", "C"});
        } catch (const PackError&) {
        }
      }
    } catch (const PackError&) {
      ++refused;
    } catch (const std::exception& e) {
      ADD_FAILURE() << what << ": " << e.what();
    }
  }
  // Both kinds happened: harmless changes (a funnel count, a tool name) open, the others are refused.
  EXPECT_GT(opened, 0u);
  EXPECT_GT(refused, 0u);
}

// Hostile and damaged packs whose checksums all agree (resealed): the reader refuses each with a PackError
// before it allocates or reads more than the files hold, and never blocks.

// Opens the pack and reads every variant of every pass, as a game would.
void open_and_read(const std::filesystem::path& manifest) {
  PackReader pack = PackReader::open(manifest);
  for (const std::string& pass : pack.passes())
    for (size_t i = 0; i < pack.variant_count(pass); ++i) pack.variant(pass, i);
}

// The child of expect_pack_error_within_limits: exits 0 when `read` throws a PackError, printing its message.
// It ends with _Exit, so it first removes its own copy of `dir` (the test body ran again in the child).
[[noreturn]] void read_within_limits(const std::function<void()>& read, const testing::TempDir& dir) {
#if !defined(__SANITIZE_ADDRESS__)  // ASan reserves terabytes of shadow memory: no address-space limit there
  const rlimit limit{uint64_t{2} << 30, uint64_t{2} << 30};
  ::setrlimit(RLIMIT_AS, &limit);
#endif
  ::alarm(60);
  int code = 2;
  try {
    read();
    std::fprintf(stderr, "no error\n");
  } catch (const PackError& e) {
    std::fprintf(stderr, "PackError: %s\n", e.what());
    code = 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "not a PackError: %s\n", e.what());
    code = 1;
  }
  std::error_code ec;
  std::filesystem::remove_all(dir.path(), ec);
  std::_Exit(code);
}

// Runs `read` in a child process (a death test) under a 2 GiB address-space limit and a 60 s alarm, so that a
// reader that allocates or reads without bound fails this test, not the machine. Passes when `read` throws a
// PackError whose message matches `message` (a POSIX extended regex).
void expect_pack_error_within_limits(const std::function<void()>& read, const std::string& message,
                                     const testing::TempDir& dir) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(read_within_limits(read, dir), ::testing::ExitedWithCode(0), message);
}

// Found by hand: 2^63 made the reader throw std::length_error when the blob was first read, and 2^32
// allocated 4 GiB before zstd said no. A raw size over the format's limit is refused when the pack is opened.
TEST(HostilePack, ABlobClaimingAHugeRawSizeIsRefusedAtOpenWithoutAllocatingIt) {
  testing::TempDir dir;
  const auto manifest = write_sample_pack(dir);
  for (uint64_t raw_size : {uint64_t{1} << 63, uint64_t{1} << 32, ~uint64_t{0}}) {
    std::string archive = testing::read_archive(manifest);
    set64(archive, compressed_entry(archive) + 16, raw_size);
    testing::reseal_pack(manifest, archive);
    expect_pack_error_within_limits([&] { open_and_read(manifest); },
                                    "PackError: blob 2: raw size " + std::to_string(raw_size) +
                                        " is over the pack format's limit of 268435456 bytes", dir);
  }
}

// A manifest is checked before it is parsed, and the room its tree needs is asked for first: a resealed 120 MiB
// manifest under a 2 GiB address-space limit is Code::OutOfMemory, where the parse used to run out half-way and end
// the process (std::bad_alloc in a destructor) or escape as std::bad_alloc.
TEST(HostilePack, AManifestTooLargeForTheAddressSpaceIsAnOutOfMemoryPackError) {
  testing::TempDir dir;
  const auto manifest = write_sample_pack(dir);
  std::string text = testing::read_file(manifest);
  std::string pad = "\"pad\": [0";
  pad.reserve(size_t{120} << 20);
  while (pad.size() < (size_t{120} << 20)) pad += ",0,0,0,0,0,0,0,0";
  pad += "],\n ";  // a top-level key of its own line, as kiln writes them
  text.insert(text.find("\"format_version\""), pad);
  std::ofstream(manifest, std::ios::binary) << testing::resealed_manifest(std::move(text));
  // A game's open never parses it; a tool's does, and so does manifest() after a game's open.
  expect_pack_error_within_limits([&] { PackReader::open(manifest, PackReader::Check::Full); },
                                  "PackError: the pack does not fit in the memory this process may use", dir);
  expect_pack_error_within_limits([&] { PackReader::open(manifest).manifest(); },
                                  "PackError: the manifest does not fit in the memory this process may use", dir);
}

// A manifest that records a 3 GiB archive used to make the reader read all of it before the 32-byte header said
// it was no kiln archive; the header is read and checked first.
TEST(HostilePack, AnArchiveHeaderIsCheckedBeforeTheArchiveIsRead) {
  testing::TempDir dir;
  const auto manifest = write_sample_pack(dir);
  nlohmann::json m = nlohmann::json::parse(testing::read_file(manifest));
  const uint64_t claimed = uint64_t{3} << 30;
  m["archive"]["size"] = claimed;
  std::ofstream(manifest, std::ios::binary) << testing::resealed_manifest(m.dump(1) + "\n");
  const auto archive = testing::archive_named_by(manifest);
  {
    std::ofstream(archive, std::ios::binary) << "NOTAPACK, and then nothing but a hole";
  }
  std::filesystem::resize_file(archive, claimed);  // sparse: no disk space
  expect_pack_error_within_limits([&] { PackReader::open(manifest); }, "PackError: archive of pack 'sample' has no KILNPACK header",
                                  dir);
}

// A frame's header records its content size; a table that records another raw size (here one byte more, within
// every limit) is refused when the blob is first used, before a buffer of the recorded size is made for the frame.
TEST(HostilePack, ABlobWhoseFrameHoldsAnotherSizeThanTheTableRecordsIsRefusedBeforeItIsDecompressed) {
  testing::TempDir dir;
  const auto manifest = write_sample_pack(dir);
  std::string archive = testing::read_archive(manifest);
  const size_t entry = compressed_entry(archive);
  set64(archive, entry + 16, get64(archive, entry + 16) + 1);
  testing::reseal_pack(manifest, archive);
  try {
    open_and_read(manifest);
    FAIL() << "read";
  } catch (const PackError& e) {
    EXPECT_EQ(e.code(), PackError::Code::Format);
    EXPECT_EQ(std::string(e.what()), "blob 2: its zstd frame holds " + std::to_string(kCompressedMsl.size()) +
                                         " bytes, the blob table records " + std::to_string(kCompressedMsl.size() + 1));
  }
}

// Stored bytes are a frame only when they are fewer than the raw bytes; more stored than raw is no blob kiln writes.
TEST(HostilePack, ABlobStoredLargerThanItsRawSizeIsRefusedAtOpen) {
  testing::TempDir dir;
  const auto manifest = write_sample_pack(dir);
  std::string archive = testing::read_archive(manifest);
  const size_t entry = compressed_entry(archive);
  set64(archive, entry + 16, get64(archive, entry + 8) - 1);
  testing::reseal_pack(manifest, archive);
  try {
    PackReader::open(manifest);
    FAIL() << "opened";
  } catch (const PackError& e) {
    EXPECT_EQ(e.code(), PackError::Code::Format);
    EXPECT_EQ(std::string(e.what()).rfind("blob 2: stored size ", 0), 0u) << e.what();
  }
}

// A zstd frame's header may claim any content size. One that claims 100 MiB in 17 bytes (a header and one
// run-length block of 16 bytes) is refused before it is decompressed: no frame of 17 bytes can hold more than one
// 128 KiB block.
TEST(HostilePack, AFrameClaimingMoreThanItsBytesCanHoldIsRefusedBeforeItIsDecompressed) {
  testing::TempDir dir;
  const uint64_t claimed = uint64_t{100} << 20;
  std::string frame = "\x28\xb5\x2f\xfd";  // magic
  frame += '\xe0';                           // single segment, 8-byte content size
  for (int i = 0; i < 8; ++i) frame += static_cast<char>(claimed >> (8 * i));
  const uint32_t block = 1 | (1 << 1) | (16 << 3);  // last block, run-length, 16 bytes
  for (int i = 0; i < 3; ++i) frame += static_cast<char>(block >> (8 * i));
  frame += 'k';
  ASSERT_EQ(frame.size(), 17u);
  ArchiveBuilder archive;
  PackedBlob blob;
  blob.stored = frame;
  blob.raw_size = claimed;
  archive.add(blob);
  Manifest manifest;
  manifest.format_version = kPackFormatVersion;
  manifest.name = "sample";
  ASSERT_TRUE(write_pack(dir.path(), "sample", archive, manifest));
  try {
    PackReader::open(dir / "sample.manifest.json").blob(0);
    FAIL() << "read";
  } catch (const PackError& e) {
    EXPECT_EQ(e.code(), PackError::Code::Format);
    EXPECT_EQ(std::string(e.what()), "blob 0: a zstd frame of 17 bytes cannot hold 104857600");
  }
}

// Found by hand: a FIFO in place of the archive or the manifest blocked open() forever. The reader opens without
// blocking and reads regular files only. If open() does block, the test unblocks it by opening the FIFO itself.
TEST(HostilePack, AFifoInPlaceOfTheArchiveOrTheManifestIsRefusedWithoutBlocking) {
  testing::TempDir dir;
  const auto manifest = write_sample_pack(dir);
  const std::filesystem::path archive = testing::archive_named_by(manifest);
  for (const std::filesystem::path& fifo : {archive, manifest}) {
    std::filesystem::remove(fifo);
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
    auto opened = std::async(std::launch::async, [&] {
      try {
        PackReader::open(fifo == manifest ? dir.path() : manifest);
        return std::string("opened");
      } catch (const PackError& e) {
        return e.file() + ": " + e.what();
      }
    });
    if (opened.wait_for(std::chrono::seconds(10)) != std::future_status::ready) {
      ADD_FAILURE() << "open() blocked on the FIFO " << fifo;
      ::close(::open(fifo.c_str(), O_WRONLY));
    }
    EXPECT_EQ(opened.get(), fifo.string() + ": a FIFO, not a regular file");
    std::filesystem::remove(fifo);
    write_sample_pack(dir);
  }
}

// Found by hand: a 64 GiB sparse file in place of the archive was read whole. Its size is checked against the
// manifest's record before a byte is read; and a manifest that records such a size (here with a checksum that
// cannot match, which the reader never gets to) is refused by the format's limit, as is a manifest that large.
TEST(HostilePack, AnArchiveOrManifestOfTheWrongOrAHugeSizeIsRefusedBeforeItIsRead) {
  testing::TempDir dir;
  const auto manifest = write_sample_pack(dir);
  const std::filesystem::path archive = testing::archive_named_by(manifest);
  const uint64_t size = std::filesystem::file_size(archive), huge = uint64_t{64} << 30;
  std::filesystem::resize_file(archive, huge);
  expect_pack_error_within_limits([&] { open_and_read(manifest); },
                                  "PackError: archive of pack 'sample' is " + std::to_string(huge) + " bytes, not the " +
                                      std::to_string(size) + " its manifest records", dir);

  json m = json::parse(testing::read_file(manifest));
  m["archive"]["size"] = huge;
  dir.write("sample.manifest.json", testing::resealed_manifest(m.dump(1) + "\n"));
  expect_pack_error_within_limits([&] { open_and_read(manifest); },
                                  "PackError: archive of pack 'sample' is " + std::to_string(huge) +
                                      " bytes, over the pack format's limit of 4294967296 bytes", dir);

  std::filesystem::resize_file(manifest, huge);
  expect_pack_error_within_limits([&] { open_and_read(manifest); },
                                  "PackError: the manifest is " + std::to_string(huge) +
                                      " bytes, over the pack format's limit of 268435456 bytes", dir);
}

// Found by fuzzing: nlohmann reports a number too large for a double as out_of_range, not as a parse error;
// it escaped open() and ended the process.
TEST(HostilePack, AManifestNumberTooLargeForADoubleIsAPackError) {
  testing::TempDir dir;
  const auto manifest = write_sample_pack(dir);
  std::string text = testing::read_file(manifest);
  text.replace(text.find("\"format_version\": "), 18, "\"format_version\": 3e999, \"v\": ");
  dir.write("sample.manifest.json", testing::resealed_manifest(text));
  try {
    PackReader::open(manifest, PackReader::Check::Full);
    FAIL() << "opened";
  } catch (const PackError& e) {
    EXPECT_EQ(e.code(), PackError::Code::Format);
    EXPECT_EQ(std::string(e.what()), "not a kiln manifest: invalid JSON: number overflow parsing '3e999'");
    EXPECT_EQ(e.file().rfind(manifest.string() + ":", 0), 0u) << e.file();  // at its line and column
  }
}

// The groups' pragmas decide which keywords fold and where their values go. A game's open parses only the manifest's
// head, so an index resealed to fold a group the JSON does not (shader_feature made dynamic_branch, the same length)
// was used by games while tools refused it; both refuse it now, games by comparing the pragmas with the text.
TEST(HostilePack, AGamesOpenRefusesAnIndexWhosePragmasFoldKeywordsTheManifestDoesNot) {
  testing::TempDir dir;
  ArchiveBuilder archive;
  Manifest manifest;
  manifest.format_version = kPackFormatVersion;
  manifest.name = "folds";
  manifest.binaries.push_back({Stage::Fragment, "F", {{Target::Spirv, archive.add("SPIRV-BYTES")}}, 0});
  manifest.reflections.emplace_back();
  for (const char* name : {"P", "Q"}) {
    ManifestPass& pass = manifest.passes.emplace_back();
    pass.name = name;
    pass.entry_points[Stage::Fragment] = "F";
    pass.keyword_groups = {{"multi_compile", {"", "M"}, kAllStageBits}, {"shader_feature", {"", "A"}, kAllStageBits}};
    for (auto keywords : std::vector<std::vector<std::string>>{{}, {"A"}, {"M"}, {"A", "M"}})
      pass.variants.push_back({keywords, {{Stage::Fragment, 0}}});
  }
  ASSERT_TRUE(write_pack(dir.path(), "folds", archive, manifest));
  const auto manifest_file = dir / "folds.manifest.json";
  EXPECT_TRUE(PackReader::open(manifest_file).variant("Q", 1).values.empty());  // nothing folds

  std::string bytes = testing::read_archive(manifest_file);
  const size_t index_end = get64(bytes, 32) + get64(bytes, 40);
  const size_t at = bytes.rfind("shader_feature", index_end);  // pass Q's second group
  ASSERT_NE(at, std::string::npos);
  ASSERT_GT(at, get64(bytes, 32));
  bytes.replace(at, 14, "dynamic_branch");
  testing::reseal_pack(manifest_file, bytes);
  for (PackReader::Check check : {PackReader::Check::OnUse, PackReader::Check::Full}) {
    try {
      PackReader::open(manifest_file, check);
      ADD_FAILURE() << "opened";
    } catch (const PackError& e) {
      EXPECT_EQ(e.code(), PackError::Code::Format);
      EXPECT_EQ(std::string(e.what()), check == PackReader::Check::OnUse
                                           ? "malformed manifest: its keyword groups are not the runtime index's: group 3 "
                                             "is 'shader_feature' in the manifest, 'dynamic_branch' in the index"
                                           : "archive of pack 'folds': its runtime index does not match the manifest");
    }
  }
  // A manifest that lost a group's pragma line is refused too.
  bytes.replace(at, 14, "shader_feature");
  testing::reseal_pack(manifest_file, bytes);
  std::string text = testing::read_file(manifest_file);
  const size_t line = text.rfind("\"pragma\": \"shader_feature\"");
  ASSERT_NE(line, std::string::npos);
  text.replace(line, 8, "\"pragmas\"");
  dir.write("folds.manifest.json", testing::resealed_manifest(text));
  try {
    PackReader::open(manifest_file);
    ADD_FAILURE() << "opened";
  } catch (const PackError& e) {
    EXPECT_EQ(std::string(e.what()), "malformed manifest: its keyword groups are not the runtime index's: the manifest has 3 "
                                     "groups, the index 4");
  }
}

// The archive is written and uploaded as parts (the blobs are not copied into one buffer): the file holds exactly the
// bytes finish() joins, its checksums are over those bytes, and the parts write_pack hands back are the same bytes.
TEST(Pack, AnArchiveWrittenFromPartsIsTheBytesItsChecksumsSay) {
  testing::TempDir dir;
  ArchiveBuilder archive;
  std::vector<PackedBlob> borrowed;
  for (int i = 0; i < 1500; ++i) borrowed.push_back(pack_blob(std::string(static_cast<size_t>(i % 13 + 1), 'a' + i % 26) + std::to_string(i)));
  for (const PackedBlob& blob : borrowed) archive.add_borrowed(blob);
  archive.add(kCompressedMsl);  // owned: a zstd frame
  Manifest manifest;
  manifest.format_version = kPackFormatVersion;
  manifest.name = "parts";
  PackFiles files;
  Result<std::string> written = write_pack(dir.path(), "parts", archive, manifest, &files);
  ASSERT_TRUE(written) << written.error().message;
  const std::string on_disk = *read_binary_file(dir / *written);
  std::string joined;
  for (std::string_view part : files.archive.parts) joined += part;
  EXPECT_EQ(joined, on_disk);
  EXPECT_EQ(files.archive.size, on_disk.size());
  EXPECT_EQ(hash64(files.archive.parts), hash64(on_disk));
  EXPECT_EQ(*written, "parts." + hex64(hash64(on_disk)) + ".kpack");
  EXPECT_EQ(get64(on_disk, 16), hash64(std::string_view(on_disk).substr(kPackHeaderSize)));
  EXPECT_EQ(files.manifest, *read_binary_file(dir / "parts.manifest.json"));
  EXPECT_EQ(archive.finish(runtime::encode(manifest)).size(), on_disk.size());
  EXPECT_NO_THROW(PackReader::open(dir / "parts.manifest.json", PackReader::Check::Full));
}

TEST(Pack, ArchiveIsDeterministic) {
  ArchiveBuilder a, b;
  for (ArchiveBuilder* builder : {&a, &b}) {
    builder->add("one");
    builder->add("two");
    builder->add("one");
  }
  EXPECT_EQ(a.finish("index"), b.finish("index"));
  EXPECT_EQ(a.size(), 2u);
}

// Workers pack their outputs; the cache keeps them packed; the writer copies them as they are.
TEST(Pack, PackedBlobsRoundTripAndOnlyShrinkingFramesAreKept) {
  std::string text;
  for (int i = 0; i < 200; ++i) text += "vec3 light" + std::to_string(i) + " = normalize(L - P);\n";
  PackedBlob packed = pack_blob(text);
  EXPECT_TRUE(packed.compressed());
  EXPECT_LT(packed.stored.size(), text.size() / 3);
  EXPECT_EQ(packed.raw_size, text.size());
  EXPECT_EQ(packed.key, hash128(text));
  EXPECT_EQ(unpack_blob(packed), text);
  EXPECT_EQ(pack_blob(text), packed) << "deterministic";

  PackedBlob tiny = pack_blob("ab");  // a frame would be longer than the bytes: stored as they are
  EXPECT_FALSE(tiny.compressed());
  EXPECT_EQ(tiny.stored, "ab");
  EXPECT_EQ(unpack_blob(tiny), "ab");

  const std::vector<uint32_t> words{0x07230203u, 0x00010300u, 7u, 42u, 0u};
  PackedBlob spirv = pack_spirv(words);
  EXPECT_EQ(spirv.raw_size, 20u);
  EXPECT_EQ(static_cast<uint8_t>(unpack_blob(spirv)[0]), 0x03) << "little-endian, as the pack stores SPIR-V";
  EXPECT_EQ(unpack_spirv(spirv), words);

  PackedBlob damaged = packed;
  damaged.stored[damaged.stored.size() / 2] ^= 0x55;
  EXPECT_THROW(unpack_blob(damaged), std::runtime_error);
  PackedBlob wrong_sum = tiny;
  wrong_sum.checksum ^= 1;
  EXPECT_THROW(unpack_blob(wrong_sum), std::runtime_error);
  EXPECT_THROW(unpack_spirv(pack_blob("abc")), std::runtime_error);
}

// A packed blob and the same bytes added raw are one blob, stored once, read back the same.
TEST(Pack, PackedAndRawAddsOfTheSameBytesAreOneBlob) {
  const std::string text(4096, 'k');
  ArchiveBuilder archive;
  uint32_t a = archive.add(pack_blob(text));
  uint32_t b = archive.add(text);
  EXPECT_EQ(a, b);
  EXPECT_EQ(archive.size(), 1u);
}

}  // namespace
}  // namespace kiln
