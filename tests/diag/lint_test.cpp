// kiln lint: every rule has a test that triggers it and one that does not.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>

#include "test_support.hpp"

namespace kiln {
namespace {

using nlohmann::json;

struct Lint : ::testing::Test {
  testing::TempDir dir;
  void pack(const std::string& extra = "", int budget = 64) {
    dir.write("p.pack.json", R"({"name": "p", "budget": )" + std::to_string(budget) + R"(,
  "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}])" + extra + "}");
  }
  // Rule ids found, by running `kiln lint ... --format json`.
  std::vector<std::string> rules(std::vector<std::string> args, json* out = nullptr) {
    args.insert(args.begin(), "lint");
    args.push_back("--format");
    args.push_back("json");
    auto r = testing::run_kiln(args, dir.path());
    json report = json::parse(r.out);
    if (out) *out = report;
    std::vector<std::string> ids;
    for (const json& f : report["findings"]) ids.push_back(f["rule"]);
    return ids;
  }
  bool has(const std::vector<std::string>& ids, const std::string& id) {
    return std::find(ids.begin(), ids.end(), id) != ids.end();
  }
};

const char* kVertex = "float4 V(float4 p : POSITION) : SV_Position { return p; }\n";

TEST_F(Lint, UnusedKeywordIsReportedWhereItIsDeclared) {
  pack();
  dir.write("S.hlsl", std::string("#pragma multi_compile_fragment _ NEVER_READ\n") + kVertex + "float4 F() : SV_Target { return 1.0; }\n");
  json report;
  auto ids = rules({"p.pack.json"}, &report);
  ASSERT_TRUE(has(ids, "unused-keyword")) << report.dump(2);
  EXPECT_EQ(report["findings"][0]["line"], 1);
  EXPECT_EQ(report["findings"][0]["message"],
            "keyword 'NEVER_READ' changes no compiled code of pass 'P': every variant with it is identical to the one without");
}

TEST_F(Lint, UsedKeywordIsNotReported) {
  pack();
  dir.write("S.hlsl", std::string("#pragma multi_compile_fragment _ READ\n") + kVertex +
                          "float4 F() : SV_Target {\n#ifdef READ\n return 0.5;\n#else\n return 1.0;\n#endif\n}\n");
  EXPECT_FALSE(has(rules({"p.pack.json"}), "unused-keyword"));
}

TEST_F(Lint, TypoInATestedKeywordSuggestsTheDeclaredOne) {
  pack();
  dir.write("S.hlsl", std::string("#pragma multi_compile_fragment _ _MAIN_LIGHT_SHADOWS\n") + kVertex +
                          "float4 F() : SV_Target {\n#if defined(_MAIN_LIGHT_SHADOW)\n return 0.5;\n#endif\n"
                          "#ifdef _MAIN_LIGHT_SHADOWS\n return 0.25;\n#endif\n return 1.0;\n}\n");
  json report;
  auto ids = rules({"p.pack.json"}, &report);
  ASSERT_TRUE(has(ids, "undeclared-keyword")) << report.dump(2);
  for (const json& f : report["findings"])
    if (f["rule"] == "undeclared-keyword") {
      EXPECT_EQ(f["line"], 4);
      EXPECT_EQ(f["column"], 13);
      EXPECT_EQ(f["notes"][0], "did you mean '_MAIN_LIGHT_SHADOWS'?");
    }
}

TEST_F(Lint, DefinedMacrosAndDeclaredKeywordsAreNotTypos) {
  pack();
  dir.write("S.hlsl", std::string("#pragma multi_compile_fragment _ _FEATURE_A\n#define LIBRARY_MACRO 1\n") + kVertex +
                          "float4 F() : SV_Target {\n#if defined(_FEATURE_A) && defined(LIBRARY_MACRO)\n return 0.5;\n#endif\n return 1.0;\n}\n");
  EXPECT_FALSE(has(rules({"p.pack.json"}), "undeclared-keyword"));
}

TEST_F(Lint, MultiCompileNoSceneVariesCouldBeShaderFeature) {
  pack();
  dir.write("S.hlsl", std::string("#pragma multi_compile_fragment _ RARE\n#pragma multi_compile_fragment _ COMMON\n") + kVertex +
                          "float4 F() : SV_Target { float c = 1.0;\n#ifdef RARE\n c *= 0.5;\n#endif\n"
                          "#ifdef COMMON\n c *= 0.25;\n#endif\n return c; }\n");
  dir.write("scene.json", R"({"name": "s", "keywords": ["COMMON"]})");
  json report;
  auto ids = rules({"p.pack.json", "--scene", "scene.json"}, &report);
  int count = 0;
  for (const json& f : report["findings"])
    if (f["rule"] == "multi-compile-could-be-feature") {
      ++count;
      EXPECT_EQ(f["line"], 1);  // RARE, not COMMON
    }
  EXPECT_EQ(count, 1) << report.dump(2);
}

TEST_F(Lint, BudgetAndMissingEntryPointAreErrors) {
  pack("", 2);
  dir.write("S.hlsl", std::string("#pragma multi_compile_fragment _ A B C\n") + kVertex + "float4 F() : SV_Target { return 1.0; }\n");
  EXPECT_TRUE(has(rules({"p.pack.json"}), "budget-exceeded"));
  pack("", 64);
  EXPECT_FALSE(has(rules({"p.pack.json"}), "budget-exceeded"));
  dir.write("S.hlsl", std::string(kVertex) + "float4 Frag() : SV_Target { return 1.0; }\n");
  auto r = testing::run_kiln({"lint", "p.pack.json"}, dir.path());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("error[missing-entry-point]: entry point 'F' of the fragment stage is not defined in 'S.hlsl'"), std::string::npos) << r.err;
  dir.write("S.hlsl", std::string(kVertex) + "float4 F() : SV_Target { return 1.0; }\n");
  EXPECT_FALSE(has(rules({"p.pack.json"}), "missing-entry-point"));
}

TEST_F(Lint, FragmentInputTheVertexStageDoesNotWriteIsAnInterfaceMismatch) {
  pack();
  dir.write("S.hlsl",
            "struct VOut { float4 p : SV_Position; float2 uv : TEXCOORD0; };\n"
            "VOut V(float4 p : POSITION) { VOut o; o.p = p; o.uv = p.xy; return o; }\n"
            "float4 F(float4 p : SV_Position, float2 uv : TEXCOORD0, float3 n : TEXCOORD1) : SV_Target { return float4(uv, n.x, 1.0); }\n");
  json report;
  auto ids = rules({"p.pack.json"}, &report);
  EXPECT_TRUE(has(ids, "interface-mismatch")) << report.dump(2);
  dir.write("S.hlsl",
            "struct VOut { float4 p : SV_Position; float2 uv : TEXCOORD0; };\n"
            "VOut V(float4 p : POSITION) { VOut o; o.p = p; o.uv = p.xy; return o; }\n"
            "float4 F(VOut i) : SV_Target { return float4(i.uv, 0.0, 1.0); }\n");
  EXPECT_FALSE(has(rules({"p.pack.json"}), "interface-mismatch"));
}

TEST_F(Lint, LayoutThatDiffersBetweenVariantsIsReported) {
  pack();
  dir.write("S.hlsl",
            "#pragma multi_compile_fragment _ SWAP\n"
            "#ifdef SWAP\n[[vk::binding(1, 0)]] Texture2D tex;\n#else\n[[vk::binding(1, 0)]] cbuffer B { float4 x; };\n#endif\n"
            "[[vk::binding(2, 0)]] SamplerState smp;\n" + std::string(kVertex) +
            "#ifdef SWAP\nfloat4 F() : SV_Target { return tex.Sample(smp, float2(0.5, 0.5)); }\n"
            "#else\nfloat4 F() : SV_Target { return x; }\n#endif\n");
  EXPECT_TRUE(has(rules({"p.pack.json"}), "layout-mismatch"));
  dir.write("S.hlsl", "[[vk::binding(1, 0)]] cbuffer B { float4 x; };\n" + std::string(kVertex) + "float4 F() : SV_Target { return x; }\n");
  EXPECT_FALSE(has(rules({"p.pack.json"}), "layout-mismatch"));
}

TEST_F(Lint, SpirvValidationErrorsAreReported) {
  pack();
  // Selecting between two textures at run time cannot be legalized for Vulkan: spirv-val rejects it.
  dir.write("S.hlsl", "[[vk::binding(0, 0)]] Texture2D a;\n[[vk::binding(1, 0)]] Texture2D b;\n[[vk::binding(2, 0)]] SamplerState s;\n" +
                          std::string(kVertex) +
                          "float4 F(float4 p : SV_Position) : SV_Target { Texture2D t = a; if (p.x > 1.0) t = b; return t.Sample(s, p.xy); }\n");
  json report;
  auto ids = rules({"p.pack.json"}, &report);
  EXPECT_TRUE(has(ids, "spirv-invalid") || has(ids, "build-error")) << report.dump(2);
  dir.write("S.hlsl", "[[vk::binding(0, 0)]] Texture2D a;\n[[vk::binding(2, 0)]] SamplerState s;\n" + std::string(kVertex) +
                          "float4 F(float4 p : SV_Position) : SV_Target { return a.Sample(s, p.xy); }\n");
  EXPECT_FALSE(has(rules({"p.pack.json"}), "spirv-invalid"));
}

TEST_F(Lint, UnguardedFp16DivisionIsReportedAndAGuardedOneIsNot) {
  dir.write("half.hlsl", "half Ratio(half a, half b)\n{\n    return a / b;\n}\n"
                         "half Guarded(half a, half b)\n{\n    return a / max(b, (half)1e-3);\n}\n"
                         "half Stated(half a, half b)\n{\n    // b >= 0.25 by construction (floor applied by the caller)\n    return a / b;\n}\n"
                         "float NotFp16(float a, float b) { return a / b; }\n");
  json report;
  auto ids = rules({"half.hlsl"}, &report);
  ASSERT_EQ(std::count(ids.begin(), ids.end(), "fp16-unguarded"), 1) << report.dump(2);
  EXPECT_EQ(report["findings"][0]["line"], 3);
}

TEST_F(Lint, SarifAndTextOutputsAndWerror) {
  pack();
  dir.write("S.hlsl", std::string("#pragma multi_compile_fragment _ NEVER_READ\n") + kVertex + "float4 F() : SV_Target { return 1.0; }\n");
  auto sarif_run = testing::run_kiln({"lint", "p.pack.json", "--format", "sarif"}, dir.path());
  EXPECT_EQ(sarif_run.exit_code, 0);  // warnings only
  json sarif = json::parse(sarif_run.out);
  EXPECT_EQ(sarif["version"], "2.1.0");
  const json& run = sarif["runs"][0];
  EXPECT_EQ(run["tool"]["driver"]["name"], "kiln");
  EXPECT_GE(run["tool"]["driver"]["rules"].size(), 9u);
  ASSERT_EQ(run["results"].size(), 1u);
  EXPECT_EQ(run["results"][0]["ruleId"], "unused-keyword");
  EXPECT_EQ(run["results"][0]["locations"][0]["physicalLocation"]["artifactLocation"]["uri"], "S.hlsl");
  EXPECT_EQ(run["results"][0]["locations"][0]["physicalLocation"]["region"]["startLine"], 1);
  auto text = testing::run_kiln({"lint", "p.pack.json", "--werror"}, dir.path());
  EXPECT_EQ(text.exit_code, 1);
  EXPECT_EQ(text.err.substr(0, text.err.find('\n')),
            "S.hlsl:1:1: warning[unused-keyword]: keyword 'NEVER_READ' changes no compiled code of pass 'P': every variant "
            "with it is identical to the one without");
}

// A CI step runs `kiln lint ... --format sarif > kiln.sarif` and uploads the file: a missing input used to
// leave it empty (CLI11 refused the path before any output). It is now a finding in the chosen format.
TEST_F(Lint, AMissingInputIsAFindingInTheChosenFormat) {
  auto sarif_run = testing::run_kiln({"lint", "missing.pack.json", "--format", "sarif"}, dir.path());
  EXPECT_EQ(sarif_run.exit_code, 1);
  json sarif = json::parse(sarif_run.out);
  const json& results = sarif["runs"][0]["results"];
  ASSERT_EQ(results.size(), 1u) << sarif_run.out;
  EXPECT_EQ(results[0]["ruleId"], "build-error");
  EXPECT_EQ(results[0]["level"], "error");
  EXPECT_NE(results[0]["message"]["text"].get<std::string>().find("cannot open 'missing.pack.json'"), std::string::npos);
  std::vector<std::string> ids = rules({"Missing.hlsl"});
  EXPECT_EQ(ids, std::vector<std::string>{"build-error"});
}

// The scratch build goes under $TMPDIR, and a reproducer that a finding names is still there afterwards (lint
// used to delete the directory it had just pointed the user to).
TEST_F(Lint, ScratchIsUnderTmpdirAndAReproducerAFindingNamesIsKept) {
  pack();
  dir.write("S.hlsl", std::string(kVertex) + "float4 F(float4) : SV_Target { return 0; }\n");  // glslang 12 crashes
  std::filesystem::create_directories(dir / "tmp");
  ::setenv("TMPDIR", (dir / "tmp").c_str(), 1);
  json report;
  std::vector<std::string> ids = rules({"p.pack.json", "--no-cache"}, &report);
  ::unsetenv("TMPDIR");
  ASSERT_FALSE(report["findings"].empty());
  std::string reproducer;
  for (const json& f : report["findings"])
    for (const json& note : f["notes"])
      if (note.get<std::string>().starts_with("reproducer written to ")) reproducer = note.get<std::string>().substr(22);
  ASSERT_FALSE(reproducer.empty()) << report.dump(1);
  EXPECT_EQ(reproducer.rfind((dir / "tmp/kiln-lint-").string(), 0), 0u) << reproducer;
  EXPECT_TRUE(std::filesystem::exists(reproducer)) << reproducer;
}

// Lint judges shaders: a cache that cannot be written is not a warning --werror fails on, and --no-cache
// writes none.
TEST_F(Lint, AnUnwritableCacheIsNotAFindingAndNoCacheWritesNone) {
  pack();
  dir.write("S.hlsl", std::string(kVertex) + "float4 F() : SV_Target { return 1.0; }\n");
  dir.write("blocker", "a file where the cache directory would go\n");
  auto blocked = testing::run_kiln({"lint", "p.pack.json", "--cache", "blocker", "--werror"}, dir.path());
  EXPECT_EQ(blocked.exit_code, 0) << blocked.err;
  EXPECT_EQ(blocked.err, "kiln lint: 0 error(s), 0 warning(s)\n");
  auto uncached = testing::run_kiln({"lint", "p.pack.json", "--no-cache", "--werror"}, dir.path());
  EXPECT_EQ(uncached.exit_code, 0) << uncached.err;
  EXPECT_FALSE(std::filesystem::exists(dir / ".kiln-cache"));
}

TEST(LintBundledLibrary, TheShaderLibraryIsLintClean) {
  testing::TempDir scratch;  // lint's cache goes to the working directory: not the source tree
  auto r = testing::run_kiln({"lint", std::string(KILN_SOURCE_DIR) + "/variants/lit.pack.json", "--werror", "--scene",
                              std::string(KILN_SOURCE_DIR) + "/variants/scenes/outdoor_day.json", "--scene",
                              std::string(KILN_SOURCE_DIR) + "/variants/scenes/night_city.json", "--scene",
                              std::string(KILN_SOURCE_DIR) + "/variants/scenes/mobile.json"},
                             scratch.path());
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

}  // namespace
}  // namespace kiln
