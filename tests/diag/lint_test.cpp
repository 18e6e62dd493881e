// SPDX-License-Identifier: Apache-2.0
// kiln lint: every rule has a test that triggers it and one that does not.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <sstream>

#include "test_support.hpp"

namespace kiln {
namespace {

using nlohmann::json;

// Every SARIF file the suite produces is validated against the official SARIF 2.1.0 schema
// (tests/sarif/validate_sarif.py; python3-jsonschema).
void expect_valid_sarif(const std::string& sarif) {
  testing::TempDir scratch;
  std::filesystem::path file = scratch.write("out.sarif", sarif);
  auto r = testing::run({KILN_PYTHON, std::string(KILN_SOURCE_DIR) + "/tests/sarif/validate_sarif.py", file.string()}, scratch.path());
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err << sarif;
}

struct Lint : ::testing::Test {
  testing::TempDir dir;
  // `kiln lint ... --format sarif`, validated.
  testing::RunResult lint_sarif(std::vector<std::string> args, const std::filesystem::path& cwd = {}) {
    args.insert(args.begin(), "lint");
    args.push_back("--format");
    args.push_back("sarif");
    auto r = testing::run_kiln(args, cwd.empty() ? dir.path() : cwd);
    expect_valid_sarif(r.out);
    return r;
  }
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
                          "float4 F() : SV_Target {\n#if defined(_FEATURE_A) && defined(LIBRARY_MACRO)\n return 0.5;\n#endif\n"
                          // what kiln defines where _FEATURE_A is folded (docs/keywords.md)
                          "#if defined(KILN_FOLDED__FEATURE_A) || defined(KILN_GROUP_OF__FEATURE_A)\n return 0.25;\n#endif\n"
                          " return 1.0;\n}\n");
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

// A binding clash names both declarations: the second one is a related location in every format (SARIF
// relatedLocations, JSON "related", a located note in text), not dropped.
TEST_F(Lint, ABindingClashNamesTheSecondDeclarationInEveryFormat) {
  pack();
  dir.write("S.hlsl", "Texture2D albedo : register(t0);\nSamplerState linearSampler : register(s0);\n" + std::string(kVertex) +
                          "float4 F() : SV_Target { return albedo.Sample(linearSampler, float2(0.5, 0.5)); }\n");
  auto text = testing::run_kiln({"lint", "p.pack.json"}, dir.path());
  EXPECT_NE(text.err.find("\n  note: S.hlsl:2:14: 'linearSampler' (sampler) is declared here\n"), std::string::npos) << text.err;
  json report;
  rules({"p.pack.json"}, &report);
  ASSERT_EQ(report["findings"].size(), 1u) << report.dump(2);
  const json& finding = report["findings"][0];
  EXPECT_EQ(finding["line"], 1);
  EXPECT_EQ(finding["column"], 11);
  ASSERT_EQ(finding["related"].size(), 1u);
  EXPECT_EQ(finding["related"][0], json({{"path", "S.hlsl"}, {"line", 2}, {"column", 14},
                                         {"message", "'linearSampler' (sampler) is declared here"}}));
  json sarif = json::parse(lint_sarif({"p.pack.json", "--sarif-root", "."}).out);
  const json& related = sarif["runs"][0]["results"][0]["relatedLocations"];
  ASSERT_EQ(related.size(), 1u) << sarif.dump(2);
  EXPECT_EQ(related[0]["physicalLocation"]["artifactLocation"]["uri"], "S.hlsl");
  EXPECT_EQ(related[0]["physicalLocation"]["region"]["startLine"], 2);
  EXPECT_EQ(related[0]["physicalLocation"]["region"]["startColumn"], 14);
  EXPECT_EQ(related[0]["message"]["text"], "'linearSampler' (sampler) is declared here");
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
  auto sarif_run = lint_sarif({"p.pack.json"});
  EXPECT_EQ(sarif_run.exit_code, 0);  // warnings only
  json sarif = json::parse(sarif_run.out);
  EXPECT_EQ(sarif["version"], "2.1.0");
  const json& run = sarif["runs"][0];
  EXPECT_EQ(run["tool"]["driver"]["name"], "kiln");
  EXPECT_GE(run["tool"]["driver"]["rules"].size(), 9u);
  ASSERT_EQ(run["results"].size(), 1u);
  EXPECT_EQ(run["results"][0]["ruleId"], "unused-keyword");
  EXPECT_EQ(run["results"][0]["locations"][0]["physicalLocation"]["artifactLocation"]["uri"], "S.hlsl");
  EXPECT_EQ(run["results"][0]["locations"][0]["physicalLocation"]["artifactLocation"]["uriBaseId"], "%SRCROOT%");
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
  auto sarif_run = lint_sarif({"missing.pack.json"});
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
  // An internal compiler error has no line of its own: it is shown at the pass's definition (a SARIF region).
  const json& ice = report["findings"][0];
  EXPECT_EQ(ice["rule"], "build-error");
  EXPECT_EQ(ice["path"], "p.pack.json");
  EXPECT_EQ(ice["line"], 2);
  EXPECT_EQ(ice["column"], 24);
  EXPECT_EQ(ice["notes"].back(), "reported for 'S.hlsl'");
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

// Without --cache, lint uses kiln build's default cache (./.kiln-cache): a CI job that lints and then builds compiles
// each module once (they kept two caches, and the build compiled everything again).
TEST_F(Lint, TheDefaultCacheIsTheBuildsSoABuildAfterALintCompilesNothing) {
  pack();
  dir.write("S.hlsl", std::string(kVertex) + "float4 F() : SV_Target { return 1.0; }\n");
  auto r = testing::run_kiln({"lint", "p.pack.json"}, dir.path());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_FALSE(std::filesystem::is_empty(dir / ".kiln-cache"));
  auto built = testing::run_kiln({"build", "p.pack.json", "-o", "out", "-q", "--summary-json", "summary.json"}, dir.path());
  ASSERT_EQ(built.exit_code, 0) << built.err;
  const json summary = json::parse(testing::read_file(dir / "summary.json"));
  EXPECT_EQ(summary.at("compiled"), 0) << summary.dump(1);
  EXPECT_GT(summary.at("cache_hits"), 0) << summary.dump(1);
}

// A missing or read-only TMPDIR is no reason to fail a CI step: the scratch build falls back to /tmp (as gcc and
// glslc do). A CI step that uploads the report must never find an empty or partial file: a report that cannot
// be written is a fatal error (exit 2) that leaves none.
TEST_F(Lint, AMissingTmpdirFallsBackAndAnUnwritableReportLeavesNoFile) {
  pack();
  dir.write("S.hlsl", std::string(kVertex) + "float4 F() : SV_Target { return 1.0; }\n");
  // TMPDIR for kiln only (this process needs its own for the capture files).
  auto r = testing::run({"/usr/bin/env", "TMPDIR=" + (dir / "no-such-dir").string(), KILN_CLI_PATH, "lint", "p.pack.json",
                         "--format", "sarif", "-o", "out.sarif"},
                        dir.path());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "");
  std::string text = testing::read_file(dir / "out.sarif");
  expect_valid_sarif(text);
  EXPECT_EQ(json::parse(text)["version"], "2.1.0");
  auto unwritable = testing::run_kiln({"lint", "p.pack.json", "--format", "sarif", "-o", "missing/out.sarif"}, dir.path());
  EXPECT_EQ(unwritable.exit_code, 3);
  EXPECT_TRUE(unwritable.err.starts_with("missing/out.sarif: error[K1601]: ")) << unwritable.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "missing"));
}

// Lint's text is coloured as the build's diagnostics are (--color always, or a terminal), never in a file.
TEST_F(Lint, TextIsColouredLikeTheBuildsDiagnostics) {
  dir.write("S.hlsl", "#ifdef _TYPO_KEYWORD\n#endif\nfloat4 F() : SV_Target { return 1.0; }\n");
  auto coloured = testing::run_kiln({"--color", "always", "lint", "S.hlsl"}, dir.path());
  EXPECT_NE(coloured.err.find("\x1b[1mS.hlsl:1:8: \x1b[1;35mwarning[undeclared-keyword]:\x1b[0m\x1b[1m '_TYPO_KEYWORD'"),
            std::string::npos) << coloured.err;
  auto plain = testing::run_kiln({"--color", "never", "lint", "S.hlsl"}, dir.path());
  EXPECT_EQ(plain.err.find('\x1b'), std::string::npos) << plain.err;
  EXPECT_NE(plain.err.find("S.hlsl:1:8: warning[undeclared-keyword]: '_TYPO_KEYWORD'"), std::string::npos) << plain.err;
  auto to_file = testing::run_kiln({"--color", "always", "lint", "S.hlsl", "-o", "report.txt"}, dir.path());
  EXPECT_EQ(testing::read_file(dir / "report.txt").find('\x1b'), std::string::npos);
}

// The build's defines (the pack's, a pass's, -D) are defined for lint too: a shader that tests one is not
// reported, so --werror passes correct shaders in CI. In file mode, -D defines.
TEST_F(Lint, TheBuildsDefinesAreDefined) {
  dir.write("S.hlsl", std::string(kVertex) + "float4 F() : SV_Target {\n#if defined(USE_FANCY_FOG) || PASS_QUALITY > 1\n"
                      "  return 0.5;\n#else\n  return 1.0;\n#endif\n}\n");
  dir.write("p.pack.json", R"({"name": "p", "defines": {"USE_FANCY_FOG": 1}, "passes": [{"name": "P", "source": "S.hlsl",
      "stages": {"vertex": "V", "fragment": "F"}, "defines": {"PASS_QUALITY": 2}}]})");
  auto with_defines = testing::run_kiln({"lint", "p.pack.json", "--werror", "--no-cache"}, dir.path());
  EXPECT_EQ(with_defines.exit_code, 0) << with_defines.err;
  // Without the pack's defines, both names are reported: the rule still sees them.
  dir.write("p.pack.json", R"({"name": "p", "passes": [{"name": "P", "source": "S.hlsl",
      "stages": {"vertex": "V", "fragment": "F"}}]})");
  auto without = testing::run_kiln({"lint", "p.pack.json", "--werror", "--no-cache"}, dir.path());
  EXPECT_EQ(without.exit_code, 1);
  EXPECT_NE(without.err.find("'USE_FANCY_FOG' is tested here"), std::string::npos) << without.err;
  auto from_command_line = testing::run_kiln({"lint", "p.pack.json", "--werror", "--no-cache", "-D", "USE_FANCY_FOG",
                                              "-D", "PASS_QUALITY=2"}, dir.path());
  EXPECT_EQ(from_command_line.exit_code, 0) << from_command_line.err;
  auto file_mode = testing::run_kiln({"lint", "S.hlsl", "--werror", "-D", "USE_FANCY_FOG", "-D", "PASS_QUALITY=2"}, dir.path());
  EXPECT_EQ(file_mode.exit_code, 0) << file_mode.err;
  auto file_mode_without = testing::run_kiln({"lint", "S.hlsl", "--werror"}, dir.path());
  EXPECT_EQ(file_mode_without.exit_code, 1) << file_mode_without.err;
}

// File mode reads each file's includes (next to it, then in -I roots): names a header defines or declares are
// known. An include it cannot find is a warning that says so.
TEST_F(Lint, FileModeReadsIncludesFromIncludeRoots) {
  dir.write("lib/Defs.hlsl", "#pragma once\n#define LIB_FEATURE_X 1\n#pragma multi_compile _ _HEADER_KEYWORD\n");
  dir.write("src/Main.hlsl", "#include \"Defs.hlsl\"\n#if LIB_FEATURE_X\n#endif\n#ifdef _HEADER_KEYWORD\n#endif\n");
  json without;
  auto ids = rules({"src/Main.hlsl"}, &without);
  EXPECT_EQ(ids, (std::vector<std::string>{"build-error", "undeclared-keyword", "undeclared-keyword"})) << without.dump(1);
  EXPECT_EQ(without["findings"][0]["severity"], "warning");
  EXPECT_EQ(without["findings"][0]["message"], "cannot find include file 'Defs.hlsl'");
  EXPECT_EQ(without["warnings"], 3);
  json with;
  EXPECT_EQ(rules({"src/Main.hlsl", "-I", "lib"}, &with), std::vector<std::string>{}) << with.dump(1);
  // The included file is linted too.
  dir.write("lib/Defs.hlsl", "#pragma once\n#define LIB_FEATURE_X 1\n#pragma multi_compile _ _HEADER_KEYWORD\n#ifdef _HEADER_KEYWORX\n#endif\n");
  json typo;
  EXPECT_EQ(rules({"src/Main.hlsl", "-I", "lib"}, &typo), std::vector<std::string>{"undeclared-keyword"});
  EXPECT_EQ(typo["findings"][0]["path"], "lib/Defs.hlsl");
  EXPECT_EQ(typo["findings"][0]["notes"][0], "did you mean '_HEADER_KEYWORD'?");
}

// GitHub-style anchors of docs/lint.md's headings: lower case, spaces to '-', other punctuation dropped.
std::set<std::string> lint_doc_anchors() {
  std::set<std::string> anchors;
  std::istringstream doc(testing::read_file(std::string(KILN_SOURCE_DIR) + "/docs/lint.md"));
  for (std::string line; std::getline(doc, line);) {
    if (line.empty() || line[0] != '#') continue;
    std::string title = line.substr(line.find_first_not_of('#')), anchor;
    for (char c : title) {
      if (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_') anchor += static_cast<char>(std::tolower(c));
      else if (c == ' ') anchor += '-';
    }
    anchors.insert(anchor.substr(anchor.find_first_not_of('-')));
  }
  return anchors;
}

TEST_F(Lint, SarifRulesHaveDescriptionsAndHelpIntoDocsAnchors) {
  dir.write("S.hlsl", "float4 F() : SV_Target { return 1.0; }\n");
  json log = json::parse(lint_sarif({"S.hlsl"}).out);
  const json& rules_json = log["runs"][0]["tool"]["driver"]["rules"];
  ASSERT_EQ(rules_json.size(), 12u);
  const std::set<std::string> anchors = lint_doc_anchors();
  for (const json& rule : rules_json) {
    const std::string id = rule["id"];
    EXPECT_FALSE(rule["shortDescription"]["text"].get<std::string>().empty()) << id;
    EXPECT_GT(rule["fullDescription"]["text"].get<std::string>().size(), rule["shortDescription"]["text"].get<std::string>().size()) << id;
    EXPECT_FALSE(rule["help"]["text"].get<std::string>().empty()) << id;
    const std::string uri = rule["helpUri"];
    ASSERT_NE(uri.find("lint.md#"), std::string::npos) << uri;
    const std::string anchor = uri.substr(uri.find('#') + 1);
    EXPECT_EQ(anchor, id);
    EXPECT_TRUE(anchors.count(anchor)) << "docs/lint.md has no section '" << anchor << "'";
  }
}

// Every result has a region (a pack-level finding: the pass's definition in the pack file); URIs are relative
// to --sarif-root (default: the git work tree) through %SRCROOT%, and percent-encoded.
TEST_F(Lint, SarifResultsHaveRegionsAndRootRelativePercentEncodedUris) {
  std::filesystem::create_directories(dir / ".git");  // the work tree the default root finds
  std::filesystem::create_directories(dir / "sub");
  dir.write("my shaders/p.pack.json", "{\"name\": \"p\",\n  \"passes\": [\n    {\"name\": \"Forward\", \"source\": \"S.hlsl\", "
                                      "\"stages\": {\"vertex\": \"V\", \"fragment\": \"F\"}}]}\n");
  dir.write("my shaders/S.hlsl",
            "struct VOut { float4 p : SV_Position; float2 uv : TEXCOORD0; };\n"
            "VOut V(float4 p : POSITION) { VOut o; o.p = p; o.uv = p.xy; return o; }\n"
            "float4 F(float4 p : SV_Position, float2 uv : TEXCOORD0, float3 n : TEXCOORD1) : SV_Target { return float4(uv, n.x, 1.0); }\n");
  auto r = lint_sarif({"../my shaders/p.pack.json"}, dir / "sub");
  json log = json::parse(r.out);
  const json& run = log["runs"][0];
  EXPECT_EQ(run["originalUriBaseIds"]["%SRCROOT%"]["uri"], "file://" + dir.path().string() + "/");
  ASSERT_EQ(run["results"].size(), 1u) << r.out;
  const json& location = run["results"][0]["locations"][0]["physicalLocation"];
  EXPECT_EQ(run["results"][0]["ruleId"], "interface-mismatch");
  EXPECT_EQ(location["artifactLocation"]["uri"], "my%20shaders/S.hlsl");
  EXPECT_EQ(location["artifactLocation"]["uriBaseId"], "%SRCROOT%");
  EXPECT_EQ(location["region"]["startLine"], 3);  // the fragment input 'n' no stage before writes
  EXPECT_EQ(location["region"]["startColumn"], 64);
  // --sarif-root moves the base; a file outside it gets an absolute file: URI.
  json rooted = json::parse(lint_sarif({"../my shaders/p.pack.json", "--sarif-root", "../my shaders"}, dir / "sub").out);
  EXPECT_EQ(rooted["runs"][0]["results"][0]["locations"][0]["physicalLocation"]["artifactLocation"]["uri"], "S.hlsl");
  json outside = json::parse(lint_sarif({"../my shaders/p.pack.json", "--sarif-root", "."}, dir / "sub").out);
  EXPECT_EQ(outside["runs"][0]["results"][0]["locations"][0]["physicalLocation"]["artifactLocation"]["uri"],
            "file://" + dir.path().string() + "/my%20shaders/S.hlsl");
}

// A folded group is one module for all its values: its variants are identical by design, not unused. A folded
// keyword that no code tests as a value (only `#if defined(K)`, true for every value folded) still is.
TEST_F(Lint, FoldedKeywordsTestedAsValuesAreNotUnused) {
  pack(R"(, "keyword_kinds": {"SOFT": "specialization_constant", "FOG_A": "specialization_constant_int",
                              "FOG_B": "specialization_constant_int", "ONLY_IF": "specialization_constant"})");
  dir.write("S.hlsl", std::string("#pragma multi_compile_fragment _ SOFT\n#pragma multi_compile_fragment _ FOG_A FOG_B\n"
                                  "#pragma multi_compile_fragment _ ONLY_IF\n") +
                          kVertex +
                          "float4 F() : SV_Target {\n"
                          "  float4 c = 1.0;\n"
                          "#if defined(KILN_FOLDED_SOFT)\n  if (SOFT) c *= 0.5;\n#elif defined(SOFT)\n  c *= 0.5;\n#endif\n"
                          "#if defined(KILN_FOLDED_FOG_A)\n  if (FOG_A) c *= 0.25;\n  if (FOG_B) c *= 0.125;\n#endif\n"
                          "#if defined(ONLY_IF)\n  c *= 0.75;\n#endif\n"
                          "  return c;\n}\n");
  json report;
  rules({"p.pack.json"}, &report);
  std::vector<std::string> unused;
  for (const json& f : report["findings"])
    if (f["rule"] == "unused-keyword") unused.push_back(f["message"]);
  EXPECT_EQ(unused, std::vector<std::string>{"folded keyword 'ONLY_IF' (specialization_constant) of pass 'P' is tested by "
                                             "no code as a value: its one module is the same for every value"})
      << report.dump(2);
}

// debug.pack.json's case: a shared header of the library (shaderlib/Common.hlsl) tests an option that this pack's
// one pass does not declare but another shader of the library does. A name no shader declares is still a typo.
TEST_F(Lint, ASharedHeaderMayTestAKeywordAnotherShaderOfItsLibraryDeclares) {
  dir.write("p.pack.json", R"({"name": "p", "include_dirs": ["lib"],
  "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  dir.write("lib/Common.hlsl", "#if defined(_HALF_PRECISION)\n#define REAL half\n#else\n#define REAL float\n#endif\n"
                               "#if defined(_HALF_PRECISON)\n#endif\n");
  dir.write("lib/passes/Other.hlsl", "#pragma shader_feature_local _ _HALF_PRECISION\n");
  dir.write("S.hlsl", std::string("#include \"Common.hlsl\"\n") + kVertex + "float4 F() : SV_Target { return (REAL)1.0; }\n");
  json report;
  rules({"p.pack.json"}, &report);
  ASSERT_EQ(report["findings"].size(), 1u) << report.dump(2);
  EXPECT_EQ(report["findings"][0]["rule"], "undeclared-keyword");
  EXPECT_EQ(report["findings"][0]["line"], 6);
  EXPECT_EQ(report["findings"][0]["notes"], json::array({"did you mean '_HALF_PRECISION'?"}));
}

// A keyword one pass declares is known to every pass of the pack (a header they share tests it).
TEST_F(Lint, AKeywordAnotherPassOfThePackDeclaresIsNotUndeclared) {
  dir.write("p.pack.json", R"({"name": "p",
  "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}},
             {"name": "Q", "source": "T.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  dir.write("Shared.hlsl", "#if defined(_OPTION)\n#define VALUE 0.5\n#else\n#define VALUE 1.0\n#endif\n");
  dir.write("S.hlsl", std::string("#include \"Shared.hlsl\"\n") + kVertex + "float4 F() : SV_Target { return VALUE; }\n");
  dir.write("T.hlsl", std::string("#pragma multi_compile_fragment _ _OPTION\n#include \"Shared.hlsl\"\n") + kVertex +
                          "float4 F() : SV_Target { return VALUE; }\n");
  json report;
  EXPECT_FALSE(has(rules({"p.pack.json"}, &report), "undeclared-keyword")) << report.dump(2);
}

// `// kiln-lint: ignore RULE` on the line, `ignore-next-line RULE` on the line before (clang-tidy's NOLINT and
// NOLINTNEXTLINE); no list: every rule. Suppressed findings are listed apart, counted, and never fail --werror.
TEST_F(Lint, ACommentSuppressesAFindingOnItsLineOrTheNext) {
  dir.write("S.hlsl",
            "#ifdef _TYPO_A  // kiln-lint: ignore undeclared-keyword -- a library option\n"
            "// kiln-lint: ignore-next-line undeclared-keyword,fp16-unguarded\n"
            "#ifdef _TYPO_B\n"
            "#endif\n"
            "#endif\n"
            "#ifdef _TYPO_C  // kiln-lint: ignore fp16-unguarded\n"
            "#endif\n"
            "#ifdef _TYPO_D  // kiln-lint: ignore\n"
            "#endif\n"
            "#ifdef _TYPO_E  // kiln-lint: ignore undeclared-keywrd\n"
            "#endif\n");
  json report;
  rules({"S.hlsl"}, &report);
  std::vector<std::string> active, suppressed;
  for (const json& f : report["findings"]) active.push_back(f["rule"].get<std::string>() + ":" + std::to_string(f["line"].get<int>()));
  for (const json& f : report["suppressed_findings"]) {
    suppressed.push_back(f["rule"].get<std::string>() + ":" + std::to_string(f["line"].get<int>()));
    EXPECT_EQ(f["suppression"], "inSource");
  }
  EXPECT_EQ(active, (std::vector<std::string>{"undeclared-keyword:6", "undeclared-keyword:10", "build-error:10"})) << report.dump(2);
  EXPECT_EQ(suppressed, (std::vector<std::string>{"undeclared-keyword:1", "undeclared-keyword:3", "undeclared-keyword:8"}));
  EXPECT_EQ(report["suppressed"], 3);
  EXPECT_EQ(report["warnings"], 3);
  EXPECT_EQ(report["suppressed_findings"][0]["justification"], "a library option");
  EXPECT_EQ(report["findings"][2]["message"], "unknown lint rule 'undeclared-keywrd' in a kiln-lint comment");

  json sarif = json::parse(lint_sarif({"S.hlsl"}).out);
  int in_source = 0;
  for (const json& result : sarif["runs"][0]["results"])
    if (result.contains("suppressions")) {
      ++in_source;
      EXPECT_EQ(result["suppressions"][0]["kind"], "inSource");
    }
  EXPECT_EQ(in_source, 3);

  dir.write("S.hlsl", "#ifdef _TYPO_A  // kiln-lint: ignore undeclared-keyword\n#endif\n");
  auto r = testing::run_kiln({"lint", "S.hlsl", "--werror"}, dir.path());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "kiln lint: 0 error(s), 0 warning(s), 1 suppressed\n");
}

// --disable RULE[,RULE] and the pack's "lint": {"disable": [...]} turn rules off: SARIF kind "external".
TEST_F(Lint, RulesAreDisabledOnTheCommandLineOrInThePack) {
  dir.write("S.hlsl", "#ifdef _TYPO_A\n#endif\n");
  json report;
  rules({"S.hlsl", "--disable", "fp16-unguarded,undeclared-keyword"}, &report);
  EXPECT_TRUE(report["findings"].empty()) << report.dump(2);
  ASSERT_EQ(report["suppressed"], 1);
  EXPECT_EQ(report["suppressed_findings"][0]["suppression"], "external");
  json sarif = json::parse(lint_sarif({"S.hlsl", "--disable", "undeclared-keyword"}).out);
  EXPECT_EQ(sarif["runs"][0]["results"][0]["suppressions"], json::parse(R"([{"kind": "external"}])"));
  EXPECT_EQ(testing::run_kiln({"lint", "S.hlsl", "--werror", "--disable", "undeclared-keyword"}, dir.path()).exit_code, 0);
  EXPECT_EQ(testing::run_kiln({"lint", "S.hlsl", "--werror"}, dir.path()).exit_code, 1);
  auto unknown = testing::run_kiln({"lint", "S.hlsl", "--disable", "undeclared-keywords"}, dir.path());
  EXPECT_NE(unknown.exit_code, 0);
  EXPECT_NE(unknown.err.find("undeclared-keywords"), std::string::npos) << unknown.err;

  pack(R"(, "lint": {"disable": ["unused-keyword"]})");
  dir.write("S.hlsl", std::string("#pragma multi_compile_fragment _ NEVER_READ\n") + kVertex + "float4 F() : SV_Target { return 1.0; }\n");
  rules({"p.pack.json"}, &report);
  EXPECT_TRUE(report["findings"].empty()) << report.dump(2);
  ASSERT_EQ(report["suppressed"], 1);
  EXPECT_EQ(report["suppressed_findings"][0]["rule"], "unused-keyword");
  EXPECT_EQ(report["suppressed_findings"][0]["suppression"], "external");
  EXPECT_EQ(testing::run_kiln({"lint", "p.pack.json", "--werror"}, dir.path()).exit_code, 0);

  pack(R"(, "lint": {"disable": ["unused-keywords"]})");
  auto misspelt = testing::run_kiln({"lint", "p.pack.json"}, dir.path());
  EXPECT_EQ(misspelt.exit_code, 1);
  EXPECT_NE(misspelt.err.find("unknown lint rule 'unused-keywords' in \"lint\": \"disable\" (did you mean 'unused-keyword'?)"),
            std::string::npos)
      << misspelt.err;
}

// debug.pack.json and lit_specialized.pack.json lint clean under --werror (a cold build of each: seconds; the
// default pack, over the golden cache, is pipeline.BundledLibrary.EveryBundledPackLintsCleanUnderWerror).
TEST(LintBundledLibrary, TheSmallBundledPacksLintCleanUnderWerror) {
  testing::TempDir scratch;
  for (const char* pack : {"debug", "lit_specialized"}) {
    auto r = testing::run_kiln({"lint", std::string(KILN_SOURCE_DIR) + "/variants/" + pack + ".pack.json", "--werror", "--cache",
                                (scratch / "cache").string()},
                               scratch.path());
    EXPECT_EQ(r.exit_code, 0) << pack << ":\n" << r.err;
  }
}

TEST(LintBundledLibrary, TheShaderLibraryIsLintClean) {
  testing::TempDir scratch;  // lint's cache (./.kiln-cache) goes to the scratch directory it runs in
  auto r = testing::run_kiln({"lint", std::string(KILN_SOURCE_DIR) + "/variants/lit.pack.json", "--werror", "--scene",
                              std::string(KILN_SOURCE_DIR) + "/variants/scenes/outdoor_day.json", "--scene",
                              std::string(KILN_SOURCE_DIR) + "/variants/scenes/night_city.json", "--scene",
                              std::string(KILN_SOURCE_DIR) + "/variants/scenes/mobile.json"},
                             scratch.path());
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

}  // namespace
}  // namespace kiln
