// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "kiln/build.hpp"
#include "kiln/pack_format.hpp"
#include "kiln/pack_tools.hpp"
#include "pack/pack_writer.hpp"
#include "permutations/permutations.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

KeywordGroup group(std::vector<std::string> values, StageMask stages = kAllStageBits, bool feature = false) {
  KeywordGroup g;
  g.values = std::move(values);
  g.stages = stages;
  g.material_feature = feature;
  g.pragma = feature ? "shader_feature" : "multi_compile";
  return g;
}

struct Fixture : ::testing::Test {
  PackDefinition pack;
  std::vector<PassKeywords> passes;
  DiagnosticSink sink;
  Fixture() {
    pack.name = "test";
    pack.passes.push_back(PassDefinition{"P", "p.hlsl", {"V", "F"}, {}});
  }
  std::optional<std::vector<PassExpansion>> expand(std::vector<KeywordGroup> groups, uint64_t budget = 1 << 20,
                                                   std::vector<SceneProfile> scenes = {}) {
    passes = {PassKeywords{&pack.passes[0], std::move(groups)}};
    StripRules rules{&pack.constraints, &scenes, &pack.materials};
    return expand_and_strip(passes, rules, budget, pack, sink);
  }
};

TEST_F(Fixture, DeclaredCountIsTheProductOfGroupSizes) {
  auto e = expand({group({"", "A", "B"}), group({"", "C"}), group({"", "F1", "F2", "F3"})});
  ASSERT_TRUE(e);
  EXPECT_EQ((*e)[0].declared.value, 24u);
  EXPECT_EQ((*e)[0].variants.size(), 24u);
}

TEST_F(Fixture, ConstraintsRemoveInvalidCombinations) {
  pack.constraints.push_back({"B", {"C"}, {}, {}, "", {}});   // B requires C
  pack.constraints.push_back({"F1", {}, {"A", "B"}, {}, "", {}});  // F1 requires A or B
  pack.constraints.push_back({"F2", {}, {}, {"C"}, "", {}});  // F2 excludes C
  auto e = expand({group({"", "A", "B"}), group({"", "C"}), group({"", "F1", "F2"})});
  ASSERT_TRUE(e);
  // Brute force over the 18 combinations.
  size_t expected = 0;
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < 2; ++c)
      for (int f = 0; f < 3; ++f) {
        bool ok = !(a == 2 && c == 0) && !(f == 1 && a == 0) && !(f == 2 && c == 1);
        expected += ok;
      }
  EXPECT_EQ((*e)[0].variants.size(), expected);
  EXPECT_EQ((*e)[0].valid.value, expected);
  for (const Variant& v : (*e)[0].variants) EXPECT_TRUE(satisfies_constraints(passes[0], pack.constraints, v));
}

TEST_F(Fixture, ValidCountMatchesBruteForceForRandomConstraints) {
  std::mt19937 random(7);
  std::vector<std::string> names;
  std::vector<KeywordGroup> groups;
  for (int g = 0; g < 6; ++g) {
    std::vector<std::string> values{""};
    for (int v = 0; v < 1 + g % 3; ++v) {
      names.push_back("K" + std::to_string(g) + "_" + std::to_string(v));
      values.push_back(names.back());
    }
    groups.push_back(group(values));
  }
  for (int i = 0; i < 5; ++i) {
    Constraint c;
    c.keyword = names[random() % names.size()];
    (i % 2 ? c.requires_any : c.excludes).push_back(names[random() % names.size()]);
    pack.constraints.push_back(c);
  }
  auto e = expand(groups);
  ASSERT_TRUE(e);
  size_t brute = 0;
  std::vector<uint16_t> choice(groups.size(), 0);
  std::function<void(size_t)> walk = [&](size_t g) {
    if (g == groups.size()) {
      brute += satisfies_constraints(passes[0], pack.constraints, Variant{0, choice});
      return;
    }
    for (size_t v = 0; v < groups[g].values.size(); ++v) {
      choice[g] = static_cast<uint16_t>(v);
      walk(g + 1);
    }
  };
  walk(0);
  EXPECT_EQ((*e)[0].valid.value, brute);
  EXPECT_EQ((*e)[0].variants.size(), brute);
}

TEST_F(Fixture, TwoToTheFortyVariantsAreRefusedBeforeAnythingIsExpanded) {
  std::vector<KeywordGroup> groups;
  for (int i = 0; i < 40; ++i) groups.push_back(group({"", "K" + std::to_string(i)}));
  groups[3] = group({"", "BIG1", "BIG2", "BIG3"});
  // No wall-clock bound (the suite runs on loaded machines): an expansion would
  // not finish at all, and ctest's timeout fails that.
  auto e = expand(groups, 4096);
  EXPECT_FALSE(e);
  ASSERT_TRUE(sink.contains(DiagId::BudgetExceeded));
  const Diagnostic d = sink.diagnostics()[0];
  EXPECT_NE(d.message.find("more than 4096 variants"), std::string::npos) << d.message;
  EXPECT_NE(d.message.find("(2199023255552 declared)"), std::string::npos) << d.message;
  ASSERT_FALSE(d.notes.empty());
  EXPECT_NE(d.notes[0].find("BIG1 BIG2 BIG3"), std::string::npos) << d.notes[0];
}

TEST_F(Fixture, ScenesKeepOnlyWhatSomeSceneCanRequest) {
  SceneProfile day{"day.json", "", "day", {"A"}};
  SceneProfile night{"night.json", "", "night", {"C"}};
  auto e = expand({group({"", "A", "B"}), group({"", "C"})}, 1 << 20, {day, night});
  ASSERT_TRUE(e);
  // day: {_, A} x {_}; night: {_} x {_, C}; union: (_,_), (A,_), (_,C).
  EXPECT_EQ((*e)[0].variants.size(), 3u);
}

TEST_F(Fixture, MaterialsKeepOnlyTheShaderFeatureCombinationsTheyUse) {
  pack.materials.push_back({"plain", {}, {}});
  pack.materials.push_back({"fancy", {"ANISO", "BURLEY"}, {}});
  auto e = expand({group({"", "A"}), group({"", "ANISO"}, kAllStageBits, true), group({"", "BURLEY"}, kAllStageBits, true)});
  ASSERT_TRUE(e);
  // multi_compile A stays whole (2) x two feature combinations (none, both).
  EXPECT_EQ((*e)[0].variants.size(), 4u);
}

TEST(Permutations, FragmentOnlyKeywordDoesNotMultiplyVertexVariants) {
  testing::TempDir dir;
  dir.write("S.hlsl",
            "#pragma multi_compile _ BOTH\n#pragma multi_compile_fragment _ F1 F2 F3\n"
            "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
            "float4 F() : SV_Target { return 1.0; }\n");
  auto pack = dir.write("p.pack.json", R"({"name": "p", "passes": [{"name": "P", "source": "S.hlsl",
      "stages": {"vertex": "V", "fragment": "F"}}]})");
  BuildOptions options;
  options.pack_file = pack;
  DiagnosticSink sink;
  auto listing = list_variants(options, sink);
  ASSERT_TRUE(listing);
  std::set<std::vector<std::string>> vertex, fragment;
  for (const auto& v : listing->variants) {
    vertex.insert(v.stage_keywords[0].second);
    fragment.insert(v.stage_keywords[1].second);
  }
  EXPECT_EQ(listing->variants.size(), 8u);
  EXPECT_EQ(vertex.size(), 2u);
  EXPECT_EQ(fragment.size(), 8u);
}

// ---- Usage logs (docs/usage.md): input from play-test and QA machines, read by build --usage, check-usage and
// merge-usage (load_usage_logs) --------------------------------------------------------------------------------------

std::string usage_log(const std::string& pack_json, const std::string& extra = "") {
  return "{\"format\": \"kiln-usage\", \"format_version\": 1, \"pack\": " + pack_json + ", \"tags\": {},\n" + extra +
         "\"passes\": [{\"name\": \"P\", \"served\": [{\"keywords\": [], \"count\": 3}]}], \"missing_dropped\": 0}\n";
}

// A 4 MiB log of 40,000 unknown keys took 25 s (each error located by counting lines from the start, every one
// reported): the errors stop at 20, the rest are counted in one line, each is located by a search.
TEST(UsageLog, ALogOfFortyThousandUnknownKeysIsTwentyErrorsAndACountOfTheRest) {
  testing::TempDir dir;
  std::string keys;
  for (int k = 0; k < 40000; ++k) keys += "\"unknown_" + std::string(80, 'x') + std::to_string(k) + "\": 0,\n";
  ASSERT_GT(keys.size(), size_t{3} << 20);
  dir.write("big.json", usage_log("\"p\"", keys));
  DiagnosticSink sink;
  EXPECT_TRUE(load_usage_logs({(dir / "big.json").string()}, {}, sink).empty());
  const std::vector<Diagnostic> diagnostics = sink.diagnostics();
  ASSERT_EQ(diagnostics.size(), 21u);
  // The object's keys come in name order: unknown_x...0, unknown_x...1, unknown_x...10, ...
  EXPECT_EQ(diagnostics[0].message, "unknown field \"unknown_" + std::string(64 - 8, 'x') + "... (89 bytes)\" in the usage log");
  EXPECT_EQ(diagnostics[0].location.line, 2);
  EXPECT_EQ(diagnostics[0].location.column, 2);
  EXPECT_EQ(diagnostics[2].location.line, 12);  // unknown_x...10
  EXPECT_EQ(diagnostics[20].message, "... and 39980 more problems in this usage log (the first 20 are shown)");
  EXPECT_EQ(diagnostics[20].location.line, 1);
  for (const Diagnostic& d : diagnostics) EXPECT_EQ(d.id, DiagId::UsageLog);
}

// merge-usage wrote logs of pack "", "../lit" and "lit\0", which every verb that names files refuses: the pack's
// name is held to the rule of every name, and a 3 MiB one is echoed as 64 bytes and its size.
TEST(UsageLog, ALogWhosePackIsNoPackNameIsRefused) {
  testing::TempDir dir;
  const std::pair<std::string, std::string> cases[] = {
      {"\"\"", "\"pack\": '' is not a pack name: it is empty"},
      {"\"../lit\"", "\"pack\": '../lit' is not a pack name: it may only use letters, digits, '_', '-' and '.'"},
      {"\"lit\\u0000\"", "\"pack\": 'lit\\x00' is not a pack name: it may only use letters, digits, '_', '-' and '.'"},
      {"\"" + std::string(3 << 20, 'n') + "\"",
       "\"pack\": '" + std::string(64, 'n') + "... (3145728 bytes)' is not a pack name: it is longer than 128 characters"},
  };
  for (const auto& [pack, error] : cases) {
    dir.write("log.json", usage_log(pack));
    DiagnosticSink sink;
    EXPECT_TRUE(load_usage_logs({(dir / "log.json").string()}, {}, sink).empty()) << error;
    const std::vector<Diagnostic> diagnostics = sink.diagnostics();
    ASSERT_EQ(diagnostics.size(), 1u) << error;
    EXPECT_EQ(diagnostics[0].message, error);
    EXPECT_EQ(diagnostics[0].location.line, 1);
    EXPECT_EQ(diagnostics[0].location.column, 48);  // at "pack"
  }
  dir.write("log.json", usage_log("\"lit\""));
  DiagnosticSink sink;
  ASSERT_EQ(load_usage_logs({(dir / "log.json").string()}, {}, sink).size(), 1u);
}

// docs/usage.md: counts stop at the largest 64-bit number rather than wrap. check-usage's totals wrapped.
TEST(UsageLog, CheckUsageTotalsSaturateRatherThanWrap) {
  testing::TempDir dir;
  ArchiveBuilder archive;
  Manifest manifest;
  manifest.format_version = kPackFormatVersion;
  manifest.name = "p";
  manifest.binaries.push_back({Stage::Fragment, "F", {{Target::Spirv, archive.add("SPIRV")}}, 0});
  manifest.reflections.emplace_back();
  ManifestPass& pass = manifest.passes.emplace_back();
  pass.name = "P";
  pass.entry_points[Stage::Fragment] = "F";
  pass.keyword_groups = {{"multi_compile", {"", "A", "B"}, kAllStageBits}};
  pass.variants = {{{}, {{Stage::Fragment, 0}}}, {{"A"}, {{Stage::Fragment, 0}}}};
  ASSERT_TRUE(write_pack(dir.path(), "p", archive, manifest));
  const PackReader pack = PackReader::open(dir / "p.manifest.json");
  constexpr uint64_t kMax = std::numeric_limits<uint64_t>::max();
  UsageLog log;
  log.file = dir / "log.json";
  log.pack = "p";
  log.passes["P"] = {{{}, kMax, false, {}}, {{"A"}, 2, false, {}}, {{"B"}, kMax - 1, true, {}}, {{"B"}, 5, true, {}}};
  DiagnosticSink sink;
  const UsageCheck check = check_usage(pack, {log, log}, sink);
  EXPECT_EQ(check.sets, 8u);
  EXPECT_EQ(check.missed, 4u);
  EXPECT_EQ(check.requests, kMax);
  EXPECT_EQ(check.requests_missed, kMax);
}

}  // namespace
}  // namespace kiln
