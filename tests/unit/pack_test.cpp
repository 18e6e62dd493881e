#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <random>

#include "kiln/pack_format.hpp"
#include "kiln/pack_reader.hpp"
#include "pack/pack_writer.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

using nlohmann::json;

// A hand-made pack: pass P with groups {_, A, B} and {_, C}; the variant [B C] is stripped.
std::filesystem::path write_sample_pack(const testing::TempDir& dir) {
  ArchiveBuilder archive;
  uint32_t spv = archive.add("SPIRV-BYTES");
  uint32_t same = archive.add("SPIRV-BYTES");
  EXPECT_EQ(spv, same);  // deduplicated
  uint32_t glsl = archive.add("#version 450\n");
  json binaries = json::array();
  binaries.push_back({{"stage", "fragment"}, {"entry", "F"}, {"blobs", {{"spirv", spv}, {"glsl", glsl}}}, {"reflection", 0}});
  json variants = json::array();
  for (auto keywords : std::vector<std::vector<std::string>>{{}, {"A"}, {"B"}, {"C"}, {"A", "C"}})
    variants.push_back({{"keywords", keywords}, {"binaries", {{"fragment", 0}}}});
  json manifest{{"format", kManifestFormat},
                {"format_version", kPackFormatVersion},
                {"name", "sample"},
                {"passes", json::array({{{"name", "P"},
                                         {"keyword_groups", json::array({{{"values", {"_", "A", "B"}}}, {{"values", {"_", "C"}}}})},
                                         {"variants", variants}}})},
                {"binaries", binaries},
                {"reflections", json::array({json::object()})}};
  EXPECT_EQ(write_pack(dir.path(), "sample", archive, manifest).error, "");
  return dir / "sample.manifest.json";
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

TEST(Pack, CorruptedArchiveFailsItsChecksum) {
  testing::TempDir dir;
  auto manifest = write_sample_pack(dir);
  const std::filesystem::path archive = testing::archive_named_by(manifest);
  std::string bytes = testing::read_file(archive);
  bytes[bytes.size() - 3] ^= 0x40;
  std::ofstream(archive, std::ios::binary) << bytes;
  try {
    PackReader::open(manifest);
    FAIL();
  } catch (const PackError& e) {
    EXPECT_EQ(e.code(), PackError::Code::Checksum);
    EXPECT_EQ(e.file(), archive.string());  // the file at fault, for `file: error:`
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
  dir.write("sample.manifest.json", m.dump());
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

TEST(Pack, ArchiveIsDeterministic) {
  ArchiveBuilder a, b;
  for (ArchiveBuilder* builder : {&a, &b}) {
    builder->add("one");
    builder->add("two");
    builder->add("one");
  }
  EXPECT_EQ(a.finish(), b.finish());
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
