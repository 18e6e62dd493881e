// SPDX-License-Identifier: Apache-2.0
// Folded keywords (kiln/folded_keywords.hpp, docs/keywords.md) through whole builds: a dynamic_branch or
// specialization_constant group builds one module for all its values, every variant is still in the pack, and
// both reader APIs give each variant the values to set, where the compiled code declares them.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <map>
#include <set>

#include "kiln/build.hpp"
#include "kiln/fold_cost.hpp"
#include "kiln/kiln_reader.h"
#include "kiln/pack_reader.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

using nlohmann::json;

using testing::errors_of;

// A and B fold; M chooses a module. The fragment shader tests A and B with `if` where they are folded, with #if
// where they are not (docs/keywords.md), M with #if.
const char* kShader =
    "#pragma multi_compile_fragment _ M\n"
    "#pragma KIND _ A B\n"
    "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
    "float4 F() : SV_Target {\n"
    "    float r = 0.0;\n"
    "#if defined(PLACE)\n"
    "    r += Place();\n"
    "#endif\n"
    "#if defined(KILN_FOLDED_A)\n"
    "    if (A) r = 0.25;\n"
    "    if (B) r = 0.5;\n"
    "#elif defined(A)\n"
    "    r = 0.25;\n"
    "#elif defined(B)\n"
    "    r = 0.5;\n"
    "#endif\n"
    "#if defined(M)\n"
    "    r += 0.125;\n"
    "#endif\n"
    "    return float4(r, 0, 0, 1);\n"
    "}\n";

struct FoldedKeywords : ::testing::Test {
  testing::TempDir dir;

  std::vector<Define> defines;  // -D
  std::string before_fragment;  // a line of the test's own before the fragment entry point
  std::string values = "_ A B";  // the folded group's
  std::map<std::string, KeywordKind> kinds;  // --keyword-kind

  BuildOptions options(const std::string& out = "out") {
    BuildOptions options;
    options.pack_file = dir / "p.pack.json";
    options.output_dir = dir / out;
    options.cache_dir = dir / "cache";
    options.jobs = 2;
    options.worker_executable = KILN_WORKER_PATH;
    options.defines = defines;
    options.keyword_kinds = kinds;
    return options;
  }
  void write(const std::string& pragma, const std::string& pack_fields) {
    std::string shader = kShader;
    shader.replace(shader.find("KIND _ A B"), 10, pragma + " " + values);
    shader.insert(shader.find("float4 F()"), before_fragment);
    dir.write("S.hlsl", shader);
    dir.write("p.pack.json", R"({"name": "p", )" + pack_fields +
                                 R"("passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  }
  bool build(const std::string& pragma, const std::string& pack_fields, DiagnosticSink& sink, const std::string& out = "out") {
    write(pragma, pack_fields);
    return build_pack(options(out), sink).ok;
  }
  json manifest() { return json::parse(testing::read_file(dir / "out/p.manifest.json")); }
};

// The distinct fragment modules of the pack's variants.
size_t fragment_modules(const PackReader& pack) {
  std::set<std::string_view> modules;
  for (size_t v = 0; v < pack.variant_count("P"); ++v) modules.insert(pack.variant("P", v).stage("fragment")->spirv);
  return modules.size();
}

TEST_F(FoldedKeywords, ASpecializationConstantGroupIsOneModuleAndEachVariantSaysWhichConstantsToSet) {
  DiagnosticSink sink;
  ASSERT_TRUE(build("specialization_constant_fragment", "", sink)) << errors_of(sink);
  PackReader pack = PackReader::open(dir / "out");
  EXPECT_EQ(pack.variant_count("P"), 6u);  // {_, A, B} x {_, M}: every variant is still selectable
  EXPECT_EQ(fragment_modules(pack), 2u);   // one per value of M only

  const SelectedVariant v = pack.select("P", {"B", "M"});
  ASSERT_EQ(v.values.size(), 2u);
  EXPECT_EQ(v.values[0].keyword, "A");
  EXPECT_EQ(v.values[0].kind, KeywordKind::SpecializationConstant);
  EXPECT_EQ(v.values[0].slot, kKeywordConstantIdBase);
  EXPECT_EQ(v.values[0].stages, stage_bit(Stage::Fragment));
  EXPECT_FALSE(v.values[0].on);
  EXPECT_EQ(v.values[1].keyword, "B");
  EXPECT_EQ(v.values[1].slot, kKeywordConstantIdBase + 1);
  EXPECT_TRUE(v.values[1].on);
  // The code declares them where the values say: SPIRV-Cross's macro in GLSL, a function constant in MSL.
  const StageView* fragment = v.stage("fragment");
  EXPECT_NE(fragment->glsl.find("SPIRV_CROSS_CONSTANT_ID_1001"), std::string_view::npos) << fragment->glsl;
  EXPECT_NE(fragment->msl.find("function_constant(1001)"), std::string_view::npos) << fragment->msl;
  EXPECT_TRUE(pack.select("P", {}).values[0].on == false && pack.select("P", {"A"}).values[0].on);

  // The manifest records where each lives, for people and tools.
  const json folded = manifest()["passes"][0]["folded_keywords"];
  ASSERT_EQ(folded.size(), 2u);
  EXPECT_EQ(folded[1]["keyword"], "B");
  EXPECT_EQ(folded[1]["constant_id"], kKeywordConstantIdBase + 1);
  EXPECT_EQ(folded[1]["type"], "bool");

  // The C API agrees with the C++ reader on every variant.
  kiln_pack* c_pack = nullptr;
  ASSERT_EQ(kiln_pack_open((dir / "out").c_str(), &c_pack, nullptr), KILN_OK);
  ASSERT_EQ(kiln_pass_value_count(c_pack, 0), 2u);
  for (uint32_t variant = 0; variant < kiln_variant_count(c_pack, 0); ++variant) {
    const SelectedVariant cpp = pack.variant("P", variant);
    for (uint32_t i = 0; i < 2; ++i) {
      kiln_keyword_value value{};
      ASSERT_EQ(kiln_variant_value(c_pack, 0, variant, i, &value, nullptr), KILN_OK);
      EXPECT_EQ(value.keyword, cpp.values[i].keyword);
      EXPECT_EQ(value.kind, KILN_KEYWORD_SPECIALIZATION_CONSTANT);
      EXPECT_EQ(value.slot, cpp.values[i].slot);
      EXPECT_EQ(value.stage_flags, uint32_t{KILN_STAGE_FLAG_FRAGMENT});
      EXPECT_EQ(value.on != 0, cpp.values[i].on);
    }
  }
  kiln_keyword_value past{};
  EXPECT_EQ(kiln_variant_value(c_pack, 0, 0, 2, &past, nullptr), KILN_ERROR_INVALID_ARGUMENT);
  kiln_pack_close(c_pack);
}

// An int group: one constant for the whole group, its value the place of the chosen value (the off value counted);
// each keyword is the test of that place, and KILN_GROUP_OF_<K> names the int for a switch.
TEST_F(FoldedKeywords, AnIntegerSpecializationConstantGroupIsOneConstantWhosePlaceChoosesTheValue) {
  before_fragment =
      "#define PLACE\n"
      "float Place() {\n"
      "#if defined(KILN_GROUP_OF_B)\n"
      "    switch (KILN_GROUP_OF_B) { case 2: return 2.0; case 1: return 1.0; default: return 0.0; }\n"
      "#else\n"
      "    return -1.0;\n"
      "#endif\n"
      "}\n";
  DiagnosticSink sink;
  ASSERT_TRUE(build("specialization_constant_int_fragment", "", sink)) << errors_of(sink);
  PackReader pack = PackReader::open(dir / "out");
  EXPECT_EQ(pack.variant_count("P"), 6u);
  EXPECT_EQ(fragment_modules(pack), 2u);

  const SelectedVariant v = pack.select("P", {"B", "M"});
  ASSERT_EQ(v.values.size(), 3u);  // _, A, B: every value of the group, one constant
  for (uint32_t place = 0; place < 3; ++place) {
    EXPECT_EQ(v.values[place].kind, KeywordKind::SpecializationInteger);
    EXPECT_EQ(v.values[place].slot, kKeywordConstantIdBase);
    EXPECT_EQ(v.values[place].value, place);
    EXPECT_EQ(v.values[place].on, place == 2);
    EXPECT_EQ(v.values[place].sets(), place == 2);
  }
  EXPECT_EQ(v.values[0].keyword, "");
  EXPECT_EQ(v.values[2].keyword, "B");
  EXPECT_EQ(v.values[2].data(), 2u);
  const SelectedVariant off = pack.select("P", {"M"});
  EXPECT_TRUE(off.values[0].on && !off.values[1].on && !off.values[2].on);
  EXPECT_EQ(off.values[0].data(), 0u);

  // One int constant in the code, read by the keywords' tests and by the switch.
  const StageView* fragment = v.stage("fragment");
  EXPECT_NE(fragment->glsl.find("const int _KilnGroup1000 = SPIRV_CROSS_CONSTANT_ID_1000;"), std::string_view::npos) << fragment->glsl;
  EXPECT_EQ(fragment->glsl.find("SPIRV_CROSS_CONSTANT_ID_1001"), std::string_view::npos) << fragment->glsl;
  EXPECT_NE(fragment->glsl.find("switch (_KilnGroup1000)"), std::string_view::npos) << fragment->glsl;
  EXPECT_NE(fragment->msl.find("function_constant(1000)"), std::string_view::npos) << fragment->msl;

  const json folded = manifest()["passes"][0]["folded_keywords"];
  ASSERT_EQ(folded.size(), 3u);
  EXPECT_EQ(folded[0]["keyword"], "_");
  EXPECT_EQ(folded[2]["keyword"], "B");
  EXPECT_EQ(folded[2]["kind"], "specialization_constant_int");
  EXPECT_EQ(folded[2]["type"], "int");
  EXPECT_EQ(folded[2]["constant_id"], kKeywordConstantIdBase);
  EXPECT_EQ(folded[2]["value"], 2);
  EXPECT_EQ(folded[2]["default"], 0);

  kiln_pack* c_pack = nullptr;
  ASSERT_EQ(kiln_pack_open((dir / "out").c_str(), &c_pack, nullptr), KILN_OK);
  ASSERT_EQ(kiln_pass_value_count(c_pack, 0), 3u);
  for (uint32_t variant = 0; variant < kiln_variant_count(c_pack, 0); ++variant) {
    const SelectedVariant cpp = pack.variant("P", variant);
    int on = 0;
    for (uint32_t i = 0; i < 3; ++i) {
      kiln_keyword_value value{};
      ASSERT_EQ(kiln_variant_value(c_pack, 0, variant, i, &value, nullptr), KILN_OK);
      EXPECT_EQ(value.keyword, cpp.values[i].keyword);
      EXPECT_EQ(value.kind, KILN_KEYWORD_SPECIALIZATION_INTEGER);
      EXPECT_EQ(value.slot, kKeywordConstantIdBase);
      EXPECT_EQ(value.on != 0, cpp.values[i].on);
      if (value.on) {
        EXPECT_EQ(value.value, i);
      }
      on += value.on != 0;
    }
    EXPECT_EQ(on, 1) << "variant " << variant;
  }
  kiln_pack_close(c_pack);
}

// The group's default is its off value's place, wherever the shader puts it; a group without one defaults to 0.
TEST_F(FoldedKeywords, AnIntegerGroupDefaultsToItsOffValue) {
  values = "A _ B";
  DiagnosticSink sink;
  ASSERT_TRUE(build("specialization_constant_int", "", sink)) << errors_of(sink);
  const SelectedVariant v = PackReader::open(dir / "out").select("P", {});
  ASSERT_EQ(v.values.size(), 3u);
  EXPECT_EQ(v.values[1].keyword, "");
  EXPECT_TRUE(v.values[1].on);
  EXPECT_EQ(v.values[1].data(), 1u);
  EXPECT_NE(v.stage("fragment")->glsl.find("#define SPIRV_CROSS_CONSTANT_ID_1000 1\n"), std::string_view::npos)
      << v.stage("fragment")->glsl;
  EXPECT_EQ(manifest()["passes"][0]["folded_keywords"][0]["default"], 1);
}

TEST_F(FoldedKeywords, ADynamicBranchGroupIsOneModuleReadingItsBoolsFromTheKeywordBlock) {
  DiagnosticSink sink;
  ASSERT_TRUE(build("dynamic_branch", "", sink)) << errors_of(sink);
  PackReader pack = PackReader::open(dir / "out");
  EXPECT_EQ(fragment_modules(pack), 2u);
  const SelectedVariant v = pack.select("P", {"A"});
  ASSERT_EQ(v.values.size(), 2u);
  EXPECT_EQ(v.values[0].kind, KeywordKind::DynamicBranch);
  EXPECT_EQ(v.values[0].slot, 0u);
  EXPECT_TRUE(v.values[0].on);
  EXPECT_EQ(v.values[1].slot, 4u);
  EXPECT_FALSE(v.values[1].on);
  // The reflected block has each bool at the offset the values give.
  const Resource* block = nullptr;
  for (const Resource& r : v.stage("fragment")->reflection->resources)
    if (r.name == kKeywordBlockName) block = &r;
  ASSERT_NE(block, nullptr);
  EXPECT_EQ(block->set, kKeywordBlockSet);
  EXPECT_EQ(block->binding, kKeywordBlockBinding);
  ASSERT_EQ(block->members.size(), 2u);
  EXPECT_EQ(block->members[0].name, "A");
  EXPECT_EQ(block->members[0].offset, 0u);
  EXPECT_EQ(block->members[1].name, "B");
  EXPECT_EQ(block->members[1].offset, 4u);
}

TEST_F(FoldedKeywords, APacksKeywordKindsFoldAMultiCompileGroupWithoutEditingTheShader) {
  DiagnosticSink sink;
  ASSERT_TRUE(build("multi_compile_fragment", R"("keyword_kinds": {"A": "specialization_constant"}, )", sink)) << errors_of(sink);
  PackReader pack = PackReader::open(dir / "out");
  EXPECT_EQ(fragment_modules(pack), 2u);
  EXPECT_EQ(manifest()["passes"][0]["keyword_groups"][1]["pragma"], "specialization_constant_fragment");
  EXPECT_EQ(pack.select("P", {"B"}).values.size(), 2u);

  // Without it, the same shader builds a module per value (and never reads the bools).
  DiagnosticSink plain_sink;
  ASSERT_TRUE(build("multi_compile_fragment", "", plain_sink, "plain")) << errors_of(plain_sink);
  EXPECT_EQ(fragment_modules(PackReader::open(dir / "plain")), 6u);
}

// A shader_feature group folded by the pack keeps every value, whatever the materials use: its one module serves
// them all, and the manifest records it under its folded pragma, which tools (check-scene, diff-packs) read back as a
// group that materials do not strip. As a variant group, the same materials strip it.
TEST_F(FoldedKeywords, AFoldedShaderFeatureGroupIsNotStrippedByMaterials) {
  // A material may name a keyword of the folded group (K1011 before): it strips nothing there.
  const std::string materials = R"("materials": [{"name": "plain"}, {"name": "a", "keywords": ["A"]}], )";
  DiagnosticSink sink;
  ASSERT_TRUE(build("shader_feature_fragment", R"("keyword_kinds": {"A": "dynamic_branch"}, )" + materials, sink))
      << errors_of(sink);
  PackReader pack = PackReader::open(dir / "out");
  EXPECT_EQ(pack.variant_count("P"), 6u);
  EXPECT_EQ(pack.select("P", {"B", "M"}).values.size(), 2u);
  EXPECT_EQ(manifest()["passes"][0]["keyword_groups"][1]["pragma"], "dynamic_branch_fragment");
  DiagnosticSink plain_sink;
  ASSERT_TRUE(build("shader_feature_fragment", materials, plain_sink, "plain")) << errors_of(plain_sink);
  EXPECT_EQ(PackReader::open(dir / "plain").variant_count("P"), 4u);  // {_, A} x {_, M}
}

// A shader's own specialization constant at an id kiln gives a folded keyword: the error is at the shader's number
// and names the keyword (glslang's own message has no location).
TEST_F(FoldedKeywords, AShadersConstantIdThatCollidesWithAFoldedKeywordsIsAnErrorAtItsNumber) {
  before_fragment = "[[vk::constant_id(1001)]] const int Quality = 1;\n";
  DiagnosticSink sink;
  EXPECT_FALSE(build("specialization_constant_fragment", "", sink));
  const std::string errors = errors_of(sink);
  EXPECT_NE(errors.find("S.hlsl:4:19: error[K1401]: specialization constant id 1001 is the one kiln gives folded keyword 'B'"),
            std::string::npos)
      << errors;
}

// -D of a folded keyword (kiln compile's way to choose a variant) is no macro: the folded module is built, and the
// keyword's own macro does not clash with it ("Macro redefined" before).
TEST_F(FoldedKeywords, ADefineThatNamesAFoldedKeywordOnlySelects) {
  defines = {Define{"A", "1"}, Define{"M", "1"}};
  DiagnosticSink sink;
  ASSERT_TRUE(build("specialization_constant", "", sink)) << errors_of(sink);
  PackReader pack = PackReader::open(dir / "out");
  EXPECT_EQ(fragment_modules(pack), 1u);  // M, a variant keyword, is defined in every variant by -D, as before
}

// --keyword-kind: the pack's keyword_kinds from the command line. It is part of the inputs: the same pack built
// without it into the same directory is not up to date.
TEST_F(FoldedKeywords, AKeywordKindOnTheCommandLineFoldsAGroupAndIsPartOfTheInputs) {
  kinds = {{"B", KeywordKind::SpecializationInteger}};
  DiagnosticSink sink;
  ASSERT_TRUE(build("multi_compile_fragment", "", sink)) << errors_of(sink);
  PackReader folded = PackReader::open(dir / "out");
  EXPECT_EQ(fragment_modules(folded), 2u);
  EXPECT_EQ(folded.select("P", {"A"}).values.size(), 3u);
  EXPECT_EQ(manifest()["passes"][0]["keyword_groups"][1]["pragma"], "specialization_constant_int_fragment");

  kinds.clear();
  DiagnosticSink again;
  const BuildReport plain = build_pack(options(), again);
  ASSERT_TRUE(plain.ok) << errors_of(again);
  EXPECT_FALSE(plain.up_to_date);
  EXPECT_EQ(fragment_modules(PackReader::open(dir / "out")), 6u);

  kinds = {{"NOT_DECLARED", KeywordKind::DynamicBranch}};
  DiagnosticSink unknown;
  EXPECT_FALSE(build_pack(options(), unknown).ok);
  EXPECT_NE(errors_of(unknown).find("<command line>: error[K1"), std::string::npos) << errors_of(unknown);
  EXPECT_NE(errors_of(unknown).find("unknown keyword 'NOT_DECLARED' in --keyword-kind"), std::string::npos) << errors_of(unknown);
}

// kiln fold-cost's plan (kiln/fold_cost.hpp): each group folded alone, from the plan only. A and B are seen by both
// stages (3 vertex, 3 x 2 fragment stage sources); M by the fragment stage only.
TEST_F(FoldedKeywords, FoldCostPlansEachGroupFoldedAloneAndSaysWhichSourcesAreWrittenForIt) {
  write("multi_compile", "");
  DiagnosticSink sink;
  std::optional<FoldPlan> plan = plan_folds(options(), {}, sink);
  ASSERT_TRUE(plan) << errors_of(sink);
  EXPECT_EQ(plan->variants, 6u);
  EXPECT_EQ(plan->stage_sources, 9u);
  ASSERT_EQ(plan->candidates.size(), 2u);
  EXPECT_EQ(plan->candidates[0].keywords, std::vector<std::string>{"M"});
  EXPECT_EQ(plan->candidates[0].stage_sources, 6u);  // 3 vertex + 3 fragment
  EXPECT_FALSE(plan->candidates[0].written_for_folding);
  EXPECT_EQ(plan->candidates[1].keywords, (std::vector<std::string>{"A", "B"}));
  EXPECT_EQ(plan->candidates[1].passes, std::vector<std::string>{"P"});
  EXPECT_EQ(plan->candidates[1].stage_sources, 3u);  // 1 vertex + 2 fragment
  EXPECT_TRUE(plan->candidates[1].written_for_folding);  // the shader tests KILN_FOLDED_A
  EXPECT_EQ(plan->all_folded, 3u);  // A B only: M's code is not written for folding, so it is left out

  // One keyword names its group; a cold build of it folded has the modules the plan counted (vertex and fragment).
  std::optional<FoldPlan> named = plan_folds(options(), {{"B"}}, sink);
  ASSERT_TRUE(named) << errors_of(sink);
  ASSERT_EQ(named->candidates.size(), 1u);
  std::optional<ColdBuild> cold =
      cold_build(folded_options(options(), named->candidates, KeywordKind::SpecializationConstant), dir / "cold", sink);
  ASSERT_TRUE(cold) << errors_of(sink);
  EXPECT_EQ(cold->modules, 3u);
  EXPECT_GT(cold->pack_bytes, 0u);
  EXPECT_FALSE(std::filesystem::exists(dir / "cold" / ".kiln-cache"));

  DiagnosticSink bad;
  EXPECT_FALSE(plan_folds(options(), {{"C"}}, bad));
  EXPECT_NE(errors_of(bad).find("--fold 'C': no pass declares keyword 'C'"), std::string::npos) << errors_of(bad);
  DiagnosticSink split;
  EXPECT_FALSE(plan_folds(options(), {{"A", "M"}}, split));
  EXPECT_NE(errors_of(split).find("--fold 'A,M': 'M' is not of the group of 'A'"), std::string::npos) << errors_of(split);
}

TEST_F(FoldedKeywords, OneGroupGivenTwoKindsOrAnUndeclaredKeywordIsAnError) {
  DiagnosticSink mixed;
  EXPECT_FALSE(build("multi_compile", R"("keyword_kinds": {"A": "dynamic_branch", "B": "specialization_constant"}, )", mixed));
  EXPECT_NE(errors_of(mixed).find("a group is one module or one per value"), std::string::npos) << errors_of(mixed);
  DiagnosticSink unknown;
  EXPECT_FALSE(build("multi_compile", R"("keyword_kinds": {"C": "dynamic_branch"}, )", unknown));
  EXPECT_NE(errors_of(unknown).find("unknown keyword 'C' in keyword_kinds"), std::string::npos) << errors_of(unknown);
  DiagnosticSink bad_kind;
  EXPECT_FALSE(build("multi_compile", R"("keyword_kinds": {"A": "uniform"}, )", bad_kind));
  EXPECT_NE(errors_of(bad_kind).find("must be \"variant\", \"dynamic_branch\", \"specialization_constant\" or "
                                    "\"specialization_constant_int\""),
            std::string::npos)
      << errors_of(bad_kind);
}

}  // namespace
}  // namespace kiln
