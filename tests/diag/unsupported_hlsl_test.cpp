// SPDX-License-Identifier: Apache-2.0
// HLSL that glslang 12's front end does not take (HLSL 2021, Shader Model 6.4+ intrinsics, ray tracing, mesh
// shaders, C++ spellings): the error names the construct, points at it, and says what to write instead, where
// glslang alone says "'declaration' : Expected" or "no matching overloaded function found".
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "frontend/unsupported_hlsl.hpp"
#include "kiln/pack_reader.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

struct Case {
  const char* name;
  const char* line;       // the fragment stage's line 2, where the construct is
  const char* construct;  // as the diagnostic names it
  int column;             // where the caret goes
};

const Case kCases[] = {
    {"template", "template<typename T> T Twice(T x) { return x + x; } float4 F() : SV_Target { return Twice(1.0); }",
     "templates (HLSL 2021)", 1},
    {"namespaced type",
     "namespace Lib { struct Light { float3 c; }; } float4 F() : SV_Target { Lib::Light l; l.c = 1; return float4(l.c, 1); }",
     "types declared in a namespace", 72},
    // Declared apart, an enum compiles (pipeline.HlslCompat.EnumsGiveTheSpirvOfTheirConstants); with its variable it
    // is left to glslang.
    {"enum", "enum class Mode { A, B } mode; float4 F() : SV_Target { return 1.0; }", "`enum`", 1},
    {"using", "using real = float; float4 F() : SV_Target { return 1.0; }", "type aliases with `using`", 1},
    {"float16_t", "float4 F(float4 p : SV_Position) : SV_Target { float16_t3 h = float16_t3(p.xyz); return 1.0; }",
     "the `float16_t` type names", 48},
    {"int16_t", "float4 F(float4 p : SV_Position) : SV_Target { int16_t i = 3; return i; }", "the `int16_t` type names", 48},
    {"uint16_t", "float4 F(float4 p : SV_Position) : SV_Target { uint16_t i = 3; return i; }", "the `uint16_t` type names",
     48},
    {"descriptor heap",
     "float4 F() : SV_Target { Texture2D t = ResourceDescriptorHeap[0]; return t.Load(int3(0, 0, 0)); }",
     "Shader Model 6.6 dynamic resources (`ResourceDescriptorHeap`)", 40},
    {"acceleration structure", "RaytracingAccelerationStructure scene : register(t0); float4 F() : SV_Target { return 1.0; }",
     "ray tracing (`RaytracingAccelerationStructure`)", 1},
    {"ray query", "float4 F() : SV_Target { RayQuery<RAY_FLAG_NONE> q; return 1.0; }", "inline ray tracing (`RayQuery`)", 26},
    {"packed dot", "float4 F() : SV_Target { uint a = 1, b = 2; return dot4add_u8packed(a, b, 0u); }",
     "Shader Model 6.4 packed dot products (`dot4add_u8packed`, `dot4add_i8packed`)", 52},
    {"pack_u8", "float4 F(float4 p : SV_Position) : SV_Target { return pack_u8(uint4(p)); }",
     "Shader Model 6.6 packing intrinsics (`pack_u8`, `pack_s8`, `pack_clamp_*`)", 55},
    {"static_assert", "static_assert(1 == 1, \"one\"); float4 F() : SV_Target { return 1.0; }", "`static_assert`", 1},
    {"constexpr", "constexpr float k = 2.0; float4 F() : SV_Target { return k; }", "`constexpr`", 1},
    {"operator", "struct V { float x; V operator+(V o) { V r; r.x = x + o.x; return r; } }; float4 F() : SV_Target { return 1.0; }",
     "operator overloading (HLSL 2021)", 23},
    {"bit field", "struct S { uint a : 4; uint b : 28; }; float4 F() : SV_Target { S s; s.a = 1; return s.a; }",
     "bit fields (HLSL 2021)", 12},
    {"status overload",
     "Texture2D t; SamplerState s; float4 F(float2 uv : TEXCOORD0) : SV_Target { uint st; return t.Sample(s, uv, int2(0, 0), 0.0, st); }",
     "this call of a texture method with these arguments (one it lacks: the `status` argument of Sample, SampleLevel, "
     "SampleCmp, SampleGrad, Gather and Load, which DXC uses to read a tiled resource's residency)", 94},
    {"mesh", "[outputtopology(\"triangle\")] [numthreads(1, 1, 1)] void F(out indices uint3 t[1]) { SetMeshOutputCounts(3, 1); }",
     "mesh shaders", 2},
};

// Through the CLI, as a user sees it: exit 1, the construct named at its column, the advice as a note.
TEST(UnsupportedHlsl, EachConstructIsNamedAtItsColumnWithWhatToWriteInstead) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(c.name);
    testing::TempDir dir;
    dir.write("p.pack.json", R"({"name": "p", "passes": [{"name": "P", "source": "S.hlsl",
                                  "stages": {"vertex": "V", "fragment": "F"}}]})");
    dir.write("S.hlsl", std::string("float4 V(float4 p : POSITION) : SV_Position { return p; }\n") + c.line + "\n");
    auto r = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--no-cache", "-q"}, dir.path());
    EXPECT_EQ(r.exit_code, 1);
    const std::string head = "S.hlsl:2:" + std::to_string(c.column) + ": error[K1401]: glslang 12's HLSL front end does not support " +
                             c.construct + " (it said: '";
    EXPECT_EQ(r.err.substr(0, head.size()), head) << r.err;
    EXPECT_NE(r.err.find("\n    " + std::string(c.line) + "\n    " + std::string(c.column - 1, ' ') + "^\n"), std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("(docs/bindings.md lists what glslang 12 does not take)\n"), std::string::npos) << r.err;
  }
}

// The whole text of one, and an ordinary error that only looks like one is left as glslang said it.
TEST(UnsupportedHlsl, TheMessageKeepsGlslangsWordsAndOrdinaryErrorsAreUntouched) {
  testing::TempDir dir;
  dir.write("p.pack.json", R"({"name": "p", "passes": [{"name": "P", "source": "S.hlsl",
                                "stages": {"vertex": "V", "fragment": "F"}}]})");
  dir.write("S.hlsl", "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "float4 F(float4 p : SV_Position) : SV_Target { return dot4add_u8packed(1u, 2u, 3.0).xxxx; }\n");
  auto r = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--no-cache", "-q"}, dir.path());
  EXPECT_EQ(r.err,
            "S.hlsl:2:55: error[K1401]: glslang 12's HLSL front end does not support Shader Model 6.4 packed dot products "
            "(`dot4add_u8packed`, `dot4add_i8packed`) (it said: 'dot4add_u8packed' : no matching overloaded function found)\n"
            "    float4 F(float4 p : SV_Position) : SV_Target { return dot4add_u8packed(1u, 2u, 3.0).xxxx; }\n"
            "                                                          ^\n"
            "  note: in pass 'P' vertex stage, keywords [<none>]\n"
            "  note: and in 1 more variant(s)\n"
            "  note: unpack the bytes with shifts and masks and use `dot` (docs/bindings.md lists what glslang 12 does not take)\n"
            "kiln: 1 error(s)\n");
  // A user function named like an HLSL 2021 intrinsic, called wrongly, is the user's own mistake.
  EXPECT_FALSE(recognise_unsupported_hlsl("'Select' : no matching overloaded function found", "return Select(a);"));
  EXPECT_FALSE(recognise_unsupported_hlsl("'undefinedThing' : unknown variable", "float4 c = undefinedThing;"));
  // A semantic or a ternary is no bit field; a word in a comment is no construct.
  EXPECT_FALSE(recognise_unsupported_hlsl("';' : Expected", "float4 color : COLOR0; float x = c ? a : 0;"));
  EXPECT_FALSE(recognise_unsupported_hlsl("';' : Expected", "float x = 1.0 // no static_assert here"));
}

}  // namespace
}  // namespace kiln

namespace kiln {
namespace {

// What a target cannot run is an error at the pass, naming the stage and the target, never a blob that does not
// compile there: SPIRV-Cross writes a geometry shader as an MSL function returning "unknown".
TEST(UnsupportedStages, GeometryAndTessellationForMetalAreErrorsNamingTheStage) {
  testing::TempDir dir;
  dir.write("G.hlsl", "struct V { float4 p : SV_Position; };\nV VS(float4 p : POSITION) { V v; v.p = p; return v; }\n"
                      "[maxvertexcount(3)]\nvoid GS(triangle V i[3], inout TriangleStream<V> s) { s.Append(i[0]); s.Append(i[1]); "
                      "s.Append(i[2]); }\nfloat4 PS(V v) : SV_Target { return 1.0; }\n");
  dir.write("p.pack.json", R"({"name": "p", "passes": [{"name": "Sprites", "source": "G.hlsl",
                                "stages": {"vertex": "VS", "geometry": "GS", "fragment": "PS"}}]})");
  auto r = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--no-cache", "-q"}, dir.path());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "G.hlsl: error[K1405]: cross-msl: Metal has no geometry shader stage\n"
                   "  note: in pass 'Sprites' geometry stage, keywords [<none>]\n"
                   "  note: SPIRV-Cross cannot write this for the 'msl' target; if this pass does not need it, give the pass "
                   "\"targets\" without \"msl\" (or remove it from the pack's, or build with --targets)\n"
                   "kiln: 1 error(s)\n");
  auto without_msl = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--no-cache", "-q", "--targets", "spirv,glsl,gles"},
                                       dir.path());
  EXPECT_EQ(without_msl.exit_code, 0) << without_msl.err;
}

// A pass's own "targets": the geometry pass goes without MSL in a pack whose other pass ships it; --targets narrows both.
TEST(UnsupportedStages, APassesOwnTargetsLetAGeometryPassShareAPackThatShipsMsl) {
  testing::TempDir dir;
  dir.write("G.hlsl", "struct V { float4 p : SV_Position; };\nV VS(float4 p : POSITION) { V v; v.p = p; return v; }\n"
                      "[maxvertexcount(3)]\nvoid GS(triangle V i[3], inout TriangleStream<V> s) { s.Append(i[0]); s.Append(i[1]); "
                      "s.Append(i[2]); }\nfloat4 PS(V v) : SV_Target { return 1.0; }\n");
  dir.write("p.pack.json", R"({"name": "p", "passes": [
      {"name": "Sprites", "source": "G.hlsl", "targets": ["spirv", "glsl", "gles"],
       "stages": {"vertex": "VS", "geometry": "GS", "fragment": "PS"}},
      {"name": "Plain", "source": "G.hlsl", "stages": {"vertex": "VS", "fragment": "PS"}}]})");
  auto r = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--no-cache", "-q"}, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  PackReader pack = PackReader::open(dir / "out");
  EXPECT_TRUE(pack.select("Sprites", {}).stage("geometry")->msl.empty());
  EXPECT_FALSE(pack.select("Sprites", {}).stage("geometry")->gles.empty());
  EXPECT_FALSE(pack.select("Plain", {}).stage("fragment")->msl.empty());
  const auto manifest = nlohmann::json::parse(testing::read_file(dir / "out/p.manifest.json"));
  EXPECT_EQ(manifest["passes"][0]["targets"], nlohmann::json({"spirv", "glsl", "gles"}));
  EXPECT_FALSE(manifest["passes"][1].contains("targets"));
  auto narrowed = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--no-cache", "-q", "--targets", "spirv,msl"}, dir.path());
  ASSERT_EQ(narrowed.exit_code, 0) << narrowed.err;
  PackReader spirv_only = PackReader::open(dir / "out");
  EXPECT_TRUE(spirv_only.select("Sprites", {}).stage("geometry")->gles.empty());
  EXPECT_FALSE(spirv_only.select("Sprites", {}).stage("geometry")->spirv.empty());
  EXPECT_FALSE(spirv_only.select("Plain", {}).stage("fragment")->msl.empty());
}

}  // namespace
}  // namespace kiln
