// The HLSL compatibility rewrites (frontend/hlsl_compat.hpp), through whole builds: each keeps DXC's meaning, and
// gives the SPIR-V of the spelling glslang already reads as DXC does.
#include <gtest/gtest.h>

#include "frontend/hlsl_compat.hpp"
#include "kiln/build.hpp"
#include "kiln/pack_reader.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

// Builds `source` as pass P (vertex V, fragment F) in `dir`/<name>/ and opens the pack.
PackReader build_source(const testing::TempDir& dir, const std::string& name, const std::string& source) {
  dir.write(name + "/S.hlsl", source);
  dir.write(name + "/p.pack.json",
            R"({"name": "p", "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  BuildOptions options;
  options.pack_file = dir / name / "p.pack.json";
  options.output_dir = dir / name / "out";
  options.worker_executable = KILN_WORKER_PATH;
  DiagnosticSink sink;
  BuildReport report = build_pack(options, sink);
  EXPECT_TRUE(report.ok);
  for (const Diagnostic& d : sink.diagnostics()) ADD_FAILURE() << format_diagnostic(d);
  return PackReader::open(dir / name / "out");
}

const char* kPushConstantsBody =
    " pc;\n"
    "float4 V(float4 p : POSITION) : SV_Position { return mul(pc.mvp, p); }\n"
    "float4 F() : SV_Target { return pc.tint; }\n";

// DXC users write push constants as a global of struct type; glslang 12 (and glslc) silently made it a member of the
// $Global uniform buffer at set 0, binding 0: the host pushes constants and the shader reads a buffer nobody binds.
TEST(HlslCompat, APushConstantOfStructTypeIsAPushConstantBlockAsInDxc) {
  testing::TempDir dir;
  const std::string structure = "struct PushData { float4x4 mvp; float4 tint; };\n";
  PackReader dxc = build_source(dir, "dxc", structure + "[[vk::push_constant]] PushData" + kPushConstantsBody);
  PackReader glslang = build_source(dir, "glslang", structure + "[[vk::push_constant]] ConstantBuffer<PushData>" + kPushConstantsBody);
  const SelectedVariant a = dxc.select("P", {}), b = glslang.select("P", {});
  for (const char* stage : {"vertex", "fragment"}) {
    const StageView* mine = a.stage(stage);
    const StageView* reference = b.stage(stage);
    ASSERT_TRUE(mine && reference);
    EXPECT_EQ(mine->spirv, reference->spirv) << stage << ": not the SPIR-V of the ConstantBuffer<T> spelling";
    EXPECT_EQ(mine->glsl, reference->glsl) << stage;
    EXPECT_EQ(mine->msl, reference->msl) << stage;
    ASSERT_EQ(mine->reflection->push_constants.size(), 1u) << stage;
    EXPECT_EQ(mine->reflection->push_constants[0].size, 80u) << stage;  // float4x4 + float4
    EXPECT_TRUE(mine->reflection->resources.empty()) << stage << ": a uniform buffer was made of the push constants";
    EXPECT_EQ(std::string(mine->glsl).find("_Global"), std::string::npos) << mine->glsl;
  }
  EXPECT_TRUE(dxc.manifest().passes.at(0).layout.resources.empty());
  EXPECT_EQ(dxc.manifest().passes.at(0).layout.push_constants.size(), 1u);
}

TEST(HlslCompat, ThePushConstantRewriteTouchesOnlyThatDeclaration) {
  EXPECT_EQ(rewrite_push_constants("[[vk :: push_constant]]PushData pc;\nPushData other;\n"),
            "[[vk :: push_constant]]ConstantBuffer<PushData> pc;\nPushData other;\n");
  EXPECT_EQ(rewrite_push_constants("[[vk::push_constant]] PushData pc : register(b0);"),
            "[[vk::push_constant]] ConstantBuffer<PushData> pc : register(b0);");
  // Spellings glslang already reads as DXC does, and text that only mentions the word, are left alone.
  EXPECT_FALSE(rewrite_push_constants("[[vk::push_constant]] ConstantBuffer<PushData> pc;"));
  EXPECT_FALSE(rewrite_push_constants("[[vk::push_constant]] cbuffer PC { float4 tint; };"));
  EXPECT_FALSE(rewrite_push_constants("// push_constant\nfloat push_constant_count;"));
  EXPECT_FALSE(rewrite_push_constants("[[vk::binding(0)]] PushData pc;"));
  // Lines are kept: a diagnostic after the rewrite points at the same line.
  const std::string text = "a\n[[vk::push_constant]] P p;\nb\n";
  const std::string rewritten = *rewrite_push_constants(text);
  EXPECT_EQ(rewritten, "a\n[[vk::push_constant]] ConstantBuffer<P> p;\nb\n");
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), std::count(rewritten.begin(), rewritten.end(), '\n'));
}

// HLSL 2021's select/and/or, the largest single cause of K1401 on one engine's shaders (73 of 177 files): the
// same SPIR-V as HLSL 2018's componentwise ?:, && and ||.
TEST(HlslCompat, Hlsl2021SelectAndOrGiveTheSpirvOfTheirHlsl2018Spelling) {
  testing::TempDir dir;
  const std::string head = "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                           "float4 F(float4 c : COLOR0) : SV_Target {\n  bool4 lit = c > 0.5;\n  bool4 dark = c < 0.1;\n";
  PackReader hlsl2021 = build_source(dir, "hlsl2021", head +
      "  float4 a = select(and(lit, !dark), c, float4(0, 0, 0, 1));\n"
      "  return select(or(dark, select(lit, dark, lit)), a, c * 2);\n}\n");
  PackReader hlsl2018 = build_source(dir, "hlsl2018", head +
      "  float4 a = (lit && !dark) ? c : float4(0, 0, 0, 1);\n"
      "  return (dark || (lit ? dark : lit)) ? a : c * 2;\n}\n");
  const SelectedVariant selected = hlsl2021.select("P", {}), expected = hlsl2018.select("P", {});
  const StageView* mine = selected.stage("fragment");
  const StageView* reference = expected.stage("fragment");
  ASSERT_TRUE(mine && reference);
  EXPECT_FALSE(mine->spirv.empty());
  EXPECT_EQ(mine->spirv, reference->spirv);
  EXPECT_EQ(mine->glsl, reference->glsl);
}

TEST(HlslCompat, TheIntrinsicRewriteKeepsUserFunctionsAndUnfinishedCalls) {
  EXPECT_EQ(rewrite_hlsl2021_intrinsics("x = select(a > b, f(1, 2), g[3]);"), "x = ((a > b) ? ( f(1, 2)) : ( g[3]));");
  EXPECT_EQ(rewrite_hlsl2021_intrinsics("y = or(and(a, b), c);"), "y = ((((a) && ( b))) || ( c));");
  // A library that defines its own select (HLSL 2018 code did) keeps it; members and other names are not calls.
  EXPECT_FALSE(rewrite_hlsl2021_intrinsics("float3 select(bool c, float3 a, float3 b) { return c ? a : b; }\n"
                                           "float3 x = select(t, u, v);"));
  EXPECT_FALSE(rewrite_hlsl2021_intrinsics("q.select(a, b, c); selection(a, b, c); order(a, b);"));
  EXPECT_FALSE(rewrite_hlsl2021_intrinsics("x = select(a, b);"));  // wrong count: glslang's error stays
  EXPECT_FALSE(rewrite_hlsl2021_intrinsics("x = select(a, b, c"));  // unfinished
  // Lines are kept.
  const std::string text = "x = select(a,\n  b,\n  c);\n";
  const std::string rewritten = *rewrite_hlsl2021_intrinsics(text);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), std::count(rewritten.begin(), rewritten.end(), '\n'));
}

// Swizzles of scalar literals, which DXC takes and glslang's preprocessor splits apart (`0. xxxx`): the SPIR-V of
// the parenthesized spelling.
TEST(HlslCompat, LiteralSwizzlesGiveTheSpirvOfTheirParenthesizedSpelling) {
  testing::TempDir dir;
  PackReader dxc = build_source(dir, "dxc",
      "float4 V(float4 p : POSITION) : SV_Position { return p + 0.xxxx; }\n"
      "float4 F() : SV_Target { return 1.0.xxxx * 0.5f.rrrr + 2.xxxx + 1e-3.xxxx; }\n");
  PackReader glslang = build_source(dir, "glslang",
      "float4 V(float4 p : POSITION) : SV_Position { return p + (0).xxxx; }\n"
      "float4 F() : SV_Target { return (1.0).xxxx * (0.5f).rrrr + (2).xxxx + (1e-3).xxxx; }\n");
  const SelectedVariant selected = dxc.select("P", {}), expected = glslang.select("P", {});
  for (const char* stage : {"vertex", "fragment"}) {
    const StageView* mine = selected.stage(stage);
    const StageView* reference = expected.stage(stage);
    ASSERT_TRUE(mine && reference);
    EXPECT_EQ(mine->spirv, reference->spirv) << stage;
  }
}

TEST(HlslCompat, TheSwizzleRewriteTouchesOnlyLiterals) {
  EXPECT_EQ(rewrite_literal_swizzles("return 1.0 . xxxx * 0. rg + 2u . x;"), "return (1.0).xxxx * (0).rg + (2u).x;");
  EXPECT_FALSE(rewrite_literal_swizzles("return p.xxxx + a1.xy + v[0].x + 0.5 + s.member;"));
  EXPECT_FALSE(rewrite_literal_swizzles("#line 12 \"x.hlsl\"\nfloat a = 1.0 . length;"));  // not a swizzle
  EXPECT_EQ(rewrite_literal_swizzles("#line 3\nx = 3. xy;"), "#line 3\nx = (3).xy;");
}

}  // namespace
}  // namespace kiln
