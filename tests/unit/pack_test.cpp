#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

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
  EXPECT_EQ(write_pack(dir.path(), "sample", archive, manifest), "");
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
  std::string bytes = testing::read_file(dir / "sample.kpack");
  bytes[bytes.size() - 3] ^= 0x40;
  dir.write("sample.kpack", bytes);
  try {
    PackReader::open(manifest);
    FAIL();
  } catch (const PackError& e) {
    EXPECT_EQ(e.code(), PackError::Code::Checksum);
  }
}

TEST(Pack, TruncatedArchiveIsRejected) {
  testing::TempDir dir;
  auto manifest = write_sample_pack(dir);
  std::string bytes = testing::read_file(dir / "sample.kpack");
  dir.write("sample.kpack", bytes.substr(0, bytes.size() / 2));
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
  }
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

}  // namespace
}  // namespace kiln
