// SPDX-License-Identifier: Apache-2.0
// One source file per stage (a .vert.hlsl and a .frag.hlsl, as glslc and DXC projects lay them out): each stage
// compiles its own file with its own entry point (both may be `main`), a keyword reaches the stages whose files
// declare it, and the interface between the two files is still checked.
#include <gtest/gtest.h>

#include <algorithm>

#include <nlohmann/json.hpp>

#include "kiln/pack_reader.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

struct StagePerFile : ::testing::Test {
  testing::TempDir dir;
  void SetUp() override {
    dir.write("shaders/Common.hlsl", "#pragma once\nfloat3 SkyColor(float3 d) { return lerp(float3(0.7, 0.8, 0.9), "
                                     "float3(0.2, 0.3, 0.8), saturate(d.y)); }\n");
    dir.write("shaders/Sky.vert.hlsl", "#pragma multi_compile _ WIDE_FOV\n#include \"Common.hlsl\"\n"
                                       "struct VSOut { float4 pos : SV_Position; float3 dir : TEXCOORD0; };\n"
                                       "VSOut main(float3 p : POSITION) {\n  VSOut o;\n  o.pos = float4(p.xy, 1, 1);\n"
                                       "#ifdef WIDE_FOV\n  o.dir = p * 2;\n#else\n  o.dir = p;\n#endif\n  return o;\n}\n");
    write_fragment("float3 dir : TEXCOORD0");
    dir.write("p.pack.json", R"({"name": "sky", "passes": [{"name": "Sky", "stages": {
        "vertex": {"source": "shaders/Sky.vert.hlsl"},
        "fragment": {"source": "shaders/Sky.frag.hlsl", "entry": "main"}}}]})");
  }
  void write_fragment(const std::string& input) {
    dir.write("shaders/Sky.frag.hlsl", "#pragma multi_compile _ SUN_DISC\n#include \"Common.hlsl\"\n"
                                       "float4 main(float4 pos : SV_Position, " + input + ") : SV_Target {\n"
                                       "  float3 c = SkyColor(normalize(dir.xyy));\n#ifdef SUN_DISC\n  c += pow(saturate(dir.y), 64);\n"
                                       "#endif\n  return float4(c, 1);\n}\n");
  }
};

TEST_F(StagePerFile, EachStageCompilesItsOwnFileAndItsKeywordsReachOnlyItsStage) {
  auto r = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--no-cache"}, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("4 declared -> 4 valid -> 4 after stripping -> 8 stage variants -> 4 unique per stage"), std::string::npos)
      << r.out;
  PackReader pack = PackReader::open(dir / "out");
  auto code = [&](std::vector<std::string> keywords, const char* stage) {
    return std::string(pack.select("Sky", keywords).stage(stage)->spirv);
  };
  // SUN_DISC is declared in the fragment file only: the vertex code is the same with and without it.
  EXPECT_EQ(code({"SUN_DISC"}, "vertex"), code({}, "vertex"));
  EXPECT_NE(code({"SUN_DISC"}, "fragment"), code({}, "fragment"));
  EXPECT_EQ(code({"WIDE_FOV"}, "fragment"), code({}, "fragment"));
  EXPECT_NE(code({"WIDE_FOV"}, "vertex"), code({}, "vertex"));
  EXPECT_EQ(pack.select("Sky", {}).stage("vertex")->entry_point, "main");
  EXPECT_EQ(pack.select("Sky", {}).stage("fragment")->entry_point, "main");
  auto listed = nlohmann::json::parse(testing::run_kiln({"list", "p.pack.json", "--json"}, dir.path()).out);
  const auto& variant = listed["variants"][3];
  EXPECT_EQ(variant["stages"]["vertex"], nlohmann::json({"WIDE_FOV"})) << variant.dump();
  EXPECT_EQ(variant["stages"]["fragment"], nlohmann::json({"SUN_DISC"})) << variant.dump();
}

// Two files are two chances to disagree: the build checks their interface as it checks the stages of one file,
// and lint reports the build's finding (one check).
TEST_F(StagePerFile, AMismatchedPairIsAnInterfaceMismatchForBuildAndLint) {
  auto clean = testing::run_kiln({"lint", "p.pack.json", "--no-cache", "--format", "json"}, dir.path());
  EXPECT_EQ(nlohmann::json::parse(clean.out)["errors"], 0) << clean.out;
  write_fragment("float2 dir : TEXCOORD0");
  const std::string message =
      "pass 'Sky', 4 variants, the first [<none>]: location 0 is float3 ('dir') in the vertex stage and float2 ('dir') "
      "in the fragment stage";
  auto mismatched = testing::run_kiln({"lint", "p.pack.json", "--no-cache", "--format", "json"}, dir.path());
  const auto report = nlohmann::json::parse(mismatched.out);
  ASSERT_FALSE(report["findings"].empty()) << mismatched.out;
  EXPECT_EQ(report["findings"][0]["rule"], "interface-mismatch");
  EXPECT_EQ(report["findings"][0]["message"], message);
  auto built = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--no-cache", "-q"}, dir.path());
  EXPECT_EQ(built.exit_code, 1);
  // At the fragment input's declaration in its own file, with the vertex output's declaration in a note.
  EXPECT_NE(built.err.find("shaders/Sky.frag.hlsl:3:46: error[K1410]: " + message), std::string::npos) << built.err;
  EXPECT_NE(built.err.find("shaders/Sky.vert.hlsl:3:49: note[K1410]: 'dir' is the vertex stage's output declared here"),
            std::string::npos)
      << built.err;
  size_t errors = 0;
  for (size_t at = built.err.find("error[K1410]"); at != std::string::npos; at = built.err.find("error[K1410]", at + 1)) ++errors;
  EXPECT_EQ(errors, 1u) << "one mismatch, one error: " << built.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "out/sky.manifest.json"));
}

// Vulkan's rule for one pipeline layout, not names: each stage file may call a binding by its own name and
// declare fewer members of a block; a descriptor of another type at a binding is an error; block members that
// overlap but disagree are a warning (K1411). A stage file written for another register convention takes its own
// "bindings".
struct StageLayouts : ::testing::Test {
  testing::TempDir dir;
  testing::RunResult build(const std::string& vertex_decls, const std::string& vertex_use, const std::string& fragment_decls,
                               const std::string& fragment_use, const std::string& fragment_bindings = "") {
    dir.write("V.hlsl", vertex_decls + "float4 main(float4 p : POSITION) : SV_Position { return p * " + vertex_use + "; }\n");
    dir.write("F.hlsl", fragment_decls + "float4 main() : SV_Target { return " + fragment_use + "; }\n");
    dir.write("p.pack.json", R"({"name": "p", "targets": ["spirv"], "passes": [{"name": "P", "stages": {
        "vertex": {"source": "V.hlsl"}, "fragment": {"source": "F.hlsl")" +
                                 (fragment_bindings.empty() ? "" : ", \"bindings\": " + fragment_bindings) + "}}}]}");
    return testing::run_kiln({"build", "p.pack.json", "-o", "out", "--no-cache", "-q"}, dir.path());
  }
};

TEST_F(StageLayouts, OneBindingByTwoNamesAndABlockWithFewerMembersBuild) {
  auto r = build("cbuffer Frame : register(b0) { float4 scale; };\n", "scale",
                 "cbuffer FrameConstants : register(b0) { float4 scale2; float4 tint; };\n", "scale2 * tint");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  const auto manifest = nlohmann::json::parse(testing::read_file(dir / "out/p.manifest.json"));
  const auto& resources = manifest["passes"][0]["layout"]["resources"];
  ASSERT_EQ(resources.size(), 1u) << resources.dump();
  EXPECT_EQ(resources[0]["size"], 32);  // the merged block covers both declarations
}

TEST_F(StageLayouts, AnotherDescriptorTypeAtOneBindingIsAnError) {
  auto r = build("cbuffer Frame : register(b0) { float4 scale; };\n", "scale",
                 "Texture2D<float4> albedo : register(t0);\n", "albedo.Load(int3(0, 0, 0))");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("error[K1406]: pass 'P': set 0 binding 0 holds 'Frame' (uniform_buffer) in the vertex stage and 'albedo' "
                       "(texture) in the fragment stage of the same variant, in 1 variant"),
            std::string::npos) << r.err;
  // The fragment file was written for a D3D11 convention: its own t shift moves its texture out of the way.
  r = build("cbuffer Frame : register(b0) { float4 scale; };\n", "scale", "Texture2D<float4> albedo : register(t0);\n",
            "albedo.Load(int3(0, 0, 0))", R"({"shifts": [{"register": "t", "shift": 16}]})");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto manifest = nlohmann::json::parse(testing::read_file(dir / "out/p.manifest.json"));
  const auto& resources = manifest["passes"][0]["layout"]["resources"];
  ASSERT_EQ(resources.size(), 2u) << resources.dump();
  EXPECT_EQ(resources[1]["name"], "albedo");
  EXPECT_EQ(resources[1]["binding"], 16);
}

TEST_F(StageLayouts, OverlappingMembersThatDisagreeAreAWarning) {
  auto r = build("cbuffer Frame : register(b0) { float4 scale; };\n", "scale",
                 "cbuffer Frame : register(b0) { float2 uvScale; float2 uvBias; };\n", "float4(uvScale, uvBias)");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("V.hlsl:1:9: warning[K1411]: pass 'P': the uniform_buffer at set 0 binding 0 ('Frame') is declared in "
                       "the vertex and fragment stages with overlapping members that disagree: 'scale' (float4, bytes 0-15) "
                       "and 'uvScale' (float2, bytes 0-7)"),
            std::string::npos) << r.err;
}

TEST_F(StagePerFile, AMissingStageFileIsNamedWithItsStage) {
  std::filesystem::remove(dir / "shaders/Sky.frag.hlsl");
  auto r = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--no-cache", "-q"}, dir.path());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "p.pack.json:1:38: error[K1001]: pass 'Sky': the fragment stage's source file './shaders/Sky.frag.hlsl' "
                   "does not exist\n"
                   "    {\"name\": \"sky\", \"passes\": [{\"name\": \"Sky\", \"stages\": {\n"
                   "                                         ^\n"
                   "kiln: 1 error(s)\n");
}

TEST_F(StagePerFile, AStageWithoutASourceInAPassWithoutOneIsADefinitionError) {
  dir.write("p.pack.json", R"({"name": "sky", "passes": [{"name": "Sky", "stages": {
      "vertex": {"source": "shaders/Sky.vert.hlsl"}, "fragment": "main"}}]})");
  auto r = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--no-cache", "-q"}, dir.path());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("pass 'Sky' has no \"source\" (and the pack no \"shader\") for its fragment stage: give the pass one, "
                       "or the stage {\"source\": FILE, \"entry\": NAME}"),
            std::string::npos)
      << r.err;
}

}  // namespace
}  // namespace kiln
