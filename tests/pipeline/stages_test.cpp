// One source file per stage (a .vert.hlsl and a .frag.hlsl, as glslc and DXC projects lay them out): each stage
// compiles its own file with its own entry point (both may be `main`), a keyword reaches the stages whose files
// declare it, and the interface between the two files is still checked.
#include <gtest/gtest.h>

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

// Two files are two chances to disagree: lint's interface check compares them as it compares the stages of one file.
TEST_F(StagePerFile, AMismatchedPairIsAnInterfaceMismatch) {
  auto clean = testing::run_kiln({"lint", "p.pack.json", "--no-cache", "--format", "json"}, dir.path());
  EXPECT_EQ(nlohmann::json::parse(clean.out)["errors"], 0) << clean.out;
  write_fragment("float2 dir : TEXCOORD0");
  auto mismatched = testing::run_kiln({"lint", "p.pack.json", "--no-cache", "--format", "json"}, dir.path());
  const auto report = nlohmann::json::parse(mismatched.out);
  ASSERT_FALSE(report["findings"].empty()) << mismatched.out;
  EXPECT_EQ(report["findings"][0]["rule"], "interface-mismatch");
  EXPECT_EQ(report["findings"][0]["message"],
            "pass 'Sky' [<none>]: location 0 is float3 in the vertex stage and float2 in the fragment stage");
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
