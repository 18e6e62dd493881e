// SPDX-License-Identifier: Apache-2.0
// The HLSL compatibility rewrites (frontend/hlsl_compat.hpp), through whole builds: each keeps DXC's meaning, and
// gives the SPIR-V of the spelling glslang already reads as DXC does.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <set>

#include <spirv-tools/optimizer.hpp>

#include "frontend/dxc_semantics.hpp"
#include "frontend/hlsl_compat.hpp"
#include "frontend/module_limits.hpp"
#include "frontend/nonuniform.hpp"
#include "kiln/build.hpp"
#include "kiln/pack_reader.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

// Builds `source` as pass P (vertex V, fragment F) in `dir`/<name>/ for `targets` (a JSON array, or all four) and
// opens the pack.
PackReader build_source(const testing::TempDir& dir, const std::string& name, const std::string& source,
                        const std::string& targets = R"(["spirv", "glsl", "gles", "msl"])") {
  dir.write(name + "/S.hlsl", source);
  dir.write(name + "/p.pack.json", R"({"name": "p", "targets": )" + targets +
                                       R"(, "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
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

// The attribute as DXC users format it: on a line of its own above the declaration (3 files of one collection kept
// the $Global uniform buffer, silently) or with comments between (lists and other attribute groups beside it:
// ThePushConstantRewriteTouchesOnlyThatDeclaration). And the variable name that
// starts with the attribute's word (`push_constants`: 9 files of another collection), which the rewrite took for a
// second attribute and rewrote twice, so glslang read the file's text twice ("block instance name redefinition").
TEST(HlslCompat, APushConstantAttributeIsSeenHoweverItIsFormattedAndWhateverTheVariableIsCalled) {
  testing::TempDir dir;
  const std::string structure = "struct PushData { float4x4 mvp; float4 tint; };\n";
  auto body = [](const std::string& name) {
    return " " + name + ";\nfloat4 V(float4 p : POSITION) : SV_Position { return mul(" + name + ".mvp, p); }\n"
           "float4 F() : SV_Target { return " + name + ".tint; }\n";
  };
  for (const std::string& name : {std::string("pc"), std::string("push_constants"), std::string("push_constant_data")}) {
    PackReader reference = build_source(dir, "reference_" + name, structure + "[[vk::push_constant]] ConstantBuffer<PushData>" + body(name));
    const std::map<std::string, std::string> spellings = {
        {"own_line", "[[vk::push_constant]]\nPushData" + body(name)},
        {"comments", "[[ vk :: push_constant ]] // DXC: a push-constant block\n/* per draw */\n  PushData" + body(name)},
        {"same_line", "[[vk::push_constant]] PushData" + body(name)},
    };
    const SelectedVariant expected = reference.select("P", {});
    for (const auto& [spelling, text] : spellings) {
      PackReader pack = build_source(dir, spelling + "_" + name, structure + text);
      const SelectedVariant selected = pack.select("P", {});
      for (const char* stage : {"vertex", "fragment"}) {
        const StageView* mine = selected.stage(stage);
        const StageView* theirs = expected.stage(stage);
        ASSERT_TRUE(mine && theirs) << spelling << " " << name;
        EXPECT_EQ(mine->spirv, theirs->spirv) << spelling << " " << name << " " << stage;
        ASSERT_EQ(mine->reflection->push_constants.size(), 1u) << spelling << " " << name << " " << stage;
        EXPECT_TRUE(mine->reflection->resources.empty()) << spelling << " " << name << " " << stage << ": a $Global buffer";
      }
    }
  }
  // A struct declared with its variable, named or not: declared first, then the variable (glslang 12: $Global too).
  PackReader reference = build_source(dir, "reference_inline", structure + "[[vk::push_constant]] ConstantBuffer<PushData>" + body("pc"));
  PackReader named = build_source(dir, "inline_named", "[[vk::push_constant]]\nstruct PushData { float4x4 mvp; float4 tint; }" + body("pc"));
  PackReader unnamed = build_source(dir, "inline_unnamed", "[[vk::push_constant]] struct { float4x4 mvp; float4 tint; }" + body("pc"));
  const SelectedVariant expected = reference.select("P", {}), a = named.select("P", {}), b = unnamed.select("P", {});
  for (const char* stage : {"vertex", "fragment"}) {
    ASSERT_TRUE(a.stage(stage) && b.stage(stage) && expected.stage(stage));
    EXPECT_EQ(a.stage(stage)->spirv, expected.stage(stage)->spirv) << stage;
    for (const StageView* view : {a.stage(stage), b.stage(stage)}) {
      ASSERT_EQ(view->reflection->push_constants.size(), 1u) << stage;
      EXPECT_EQ(view->reflection->push_constants[0].size, 80u) << stage;
      EXPECT_TRUE(view->reflection->resources.empty()) << stage << ": a $Global buffer";
    }
  }
}

TEST(HlslCompat, AttributeListsBecomeOneGroupPerAttribute) {
  EXPECT_EQ(rewrite_attribute_lists("[[vk::binding(0, 1), vk::push_constant]] P p;"), "[[vk::binding(0, 1)]][[ vk::push_constant]] P p;");
  EXPECT_EQ(rewrite_attribute_lists("[[vk::input_attachment_index(1),vk::binding(2),vk::location(3)]] SubpassInput s;"),
            "[[vk::input_attachment_index(1)]][[vk::binding(2)]][[vk::location(3)]] SubpassInput s;");
  EXPECT_FALSE(rewrite_attribute_lists("[[vk::binding(0, 1)]] Texture2D t; [numthreads(8, 8, 1)] void main() { a[b[0]] = c; }"));
  EXPECT_FALSE(rewrite_attribute_lists("[[vk::binding(0, 1)"));  // unfinished: glslang's error stays
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
  EXPECT_FALSE(rewrite_push_constants("[[vk::push_constants]] PushData pc;\nfloat push_constant;"));
  // Once, however the variable is named and the attribute formatted.
  EXPECT_EQ(rewrite_push_constants("[[vk::push_constant]] PushConstants push_constants;"),
            "[[vk::push_constant]] ConstantBuffer<PushConstants> push_constants;");
  EXPECT_EQ(rewrite_push_constants("[[vk::push_constant]]\n// note\n/* a\nb */ [[vk::binding(1)]]\nP\tpc\n;"),
            "[[vk::push_constant]]\n// note\n/* a\nb */ [[vk::binding(1)]]\nConstantBuffer<P>\tpc\n;");
  EXPECT_EQ(rewrite_push_constants("[[vk::binding(1), vk::push_constant]] P pc;"), "[[vk::binding(1), vk::push_constant]] ConstantBuffer<P> pc;");
  EXPECT_EQ(rewrite_push_constants("[[vk::push_constant, vk::something]] [[other]] P pc;"),
            "[[vk::push_constant, vk::something]] [[other]] ConstantBuffer<P> pc;");
  EXPECT_EQ(rewrite_push_constants("[[vk::push_constant]]\nstruct P { float4 t; } pc;\n"),
            "[[vk::push_constant]]\nstruct P { float4 t; }; [[vk::push_constant]] ConstantBuffer<P> pc;\n");
  EXPECT_EQ(rewrite_push_constants("[[vk::push_constant]] struct { float4 t; } pc;"),
            "[[vk::push_constant]] struct kiln_push_constant_pc { float4 t; }; [[vk::push_constant]] ConstantBuffer<kiln_push_constant_pc> pc;");
  EXPECT_FALSE(rewrite_push_constants("[[vk::push_constant]] struct P { float4 t; };"));
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
  const std::string head = "float4 V(float4 p : POSITION, inout float4 c : COLOR0) : SV_Position { return p; }\n"
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

// ---- NonUniformResourceIndex ------------------------------------------------------------------------------------

constexpr uint32_t kOpCapability = 17, kOpDecorate = 71, kDecorationNonUniform = 5300;
constexpr uint32_t kShaderNonUniform = 5301, kUniformBufferArrayNonUniformIndexing = 5306,
                   kSampledImageArrayNonUniformIndexing = 5307;

struct SpirvFacts {
  std::set<uint32_t> capabilities;
  std::set<uint32_t> nonuniform;             // decorated ids
  std::set<uint32_t> builtins;               // the BuiltIn decorations' values
  std::map<uint32_t, uint32_t> opcode_of;    // result id -> the opcode that defines it (function bodies)
  std::vector<uint32_t> without_nonuniform;  // the module without NonUniform and its capabilities
};

SpirvFacts facts_of(std::string_view bytes) {
  std::vector<uint32_t> words(bytes.size() / 4);
  std::memcpy(words.data(), bytes.data(), words.size() * 4);
  SpirvFacts facts;
  facts.without_nonuniform.assign(words.begin(), words.begin() + 5);
  for (size_t at = 5; at < words.size();) {
    const uint32_t count = words[at] >> 16, op = words[at] & 0xffff;
    bool keep = true;
    if (op == kOpCapability) {
      facts.capabilities.insert(words[at + 1]);
      keep = words[at + 1] != kShaderNonUniform && (words[at + 1] < 5306 || words[at + 1] > 5312);  // the *NonUniformIndexing
    }
    if (op == kOpDecorate && words[at + 2] == 11) facts.builtins.insert(words[at + 3]);  // BuiltIn
    if (op == kOpDecorate && words[at + 2] == kDecorationNonUniform) {
      facts.nonuniform.insert(words[at + 1]);
      keep = false;
    }
    // Result-bearing body instructions kiln decorates: OpAccessChain 65, OpLoad 61, OpSampledImage 86, OpImage 100.
    if ((op == 65 || op == 61 || op == 86 || op == 100) && count >= 3) facts.opcode_of[words[at + 2]] = op;
    if (keep) facts.without_nonuniform.insert(facts.without_nonuniform.end(), words.begin() + at, words.begin() + at + count);
    at += count;
  }
  return facts;
}

// A module with its ids renumbered in order of first appearance (SPIRV-Tools' compact-ids).
std::vector<uint32_t> compacted(const std::vector<uint32_t>& words) {
  spvtools::Optimizer optimizer(SPV_ENV_VULKAN_1_1);
  optimizer.RegisterPass(spvtools::CreateCompactIdsPass());
  std::vector<uint32_t> out;
  EXPECT_TRUE(optimizer.Run(words.data(), words.size(), &out));
  return out;
}

// ---- enum and RWByteAddressBuffer atomics ------------------------------------------------------------------------

// Enums as DXC users write them (unscoped with a value, `enum class` with a type, qualified and unqualified uses, a
// case label, a cast, a parameter): the SPIR-V of the same shader written with int and uint constants.
TEST(HlslCompat, EnumsGiveTheSpirvOfTheirConstants) {
  testing::TempDir dir;
  const std::string vertex = "float4 V(float4 p : POSITION) : SV_Position { return p; }\n";
  PackReader enums = build_source(dir, "enums", vertex +
      "enum Mode { Off, Fast = 3,\n  Best };\n"
      "enum class Tone : uint { Linear, Aces = Linear + 4 };\n"
      "cbuffer Params : register(b0) { int mode; uint tone; };\n"
      "float Weight(Mode m) { return m == Mode::Best ? 2.0 : 1.0; }\n"
      "float4 F() : SV_Target {\n"
      "  switch ((Mode)mode) { case Fast: return 1; case Off: return 0; default: break; }\n"
      "  Tone t = (Tone)tone;\n"
      "  return Weight((Mode)mode) * (t == Tone::Aces ? 0.5 : 1.0) + Best;\n}\n");
  PackReader constants = build_source(dir, "constants", vertex +
      "static const int Off = 0; static const int Fast = 3;\n  static const int Best = 4;\n"
      "\n"
      "cbuffer Params : register(b0) { int mode; uint tone; };\n"
      "float Weight(int m) { return m == Best ? 2.0 : 1.0; }\n"
      "float4 F() : SV_Target {\n"
      "  switch (mode) { case Fast: return 1; case Off: return 0; default: break; }\n"
      "  uint t = tone;\n"
      "  return Weight(mode) * (t == 4u ? 0.5 : 1.0) + Best;\n}\n");
  const SelectedVariant a = enums.select("P", {}), b = constants.select("P", {});
  const StageView* mine = a.stage("fragment");
  const StageView* reference = b.stage("fragment");
  ASSERT_TRUE(mine && reference);
  EXPECT_EQ(compacted(facts_of(mine->spirv).without_nonuniform), compacted(facts_of(reference->spirv).without_nonuniform));
  EXPECT_EQ(mine->glsl, reference->glsl);
  EXPECT_EQ(mine->msl, reference->msl);
}

TEST(HlslCompat, TheEnumRewriteKeepsLinesAndLeavesOtherDeclarations) {
  const std::string text = "enum E\n{\n  A = 2,\n  B,\n};\nint x = B;\n";
  const std::string rewritten = *rewrite_enums(text);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), std::count(rewritten.begin(), rewritten.end(), '\n'));
  EXPECT_NE(rewritten.find("static const int B = (int)(E::A + 1);"), std::string::npos) << rewritten;
  EXPECT_TRUE(rewritten.ends_with("\nint x = B;\n")) << rewritten;
  // An anonymous enum gives plain constants; a scoped one only qualified names.
  EXPECT_EQ(rewrite_enums("enum { Red, Green };"), " static const int Red = (int)(0); static const int Green = (int)(Red + 1);");
  EXPECT_EQ(std::string(*rewrite_enums("enum class S : uint { X };")).find("static const uint X = S::X"), std::string::npos);
  // Not enums, or not ones it can rewrite (a declarator after the body): glslang's message stays.
  EXPECT_FALSE(rewrite_enums("int enumerate = 1; s.enum_value = 2;"));
  EXPECT_FALSE(rewrite_enums("enum E { A } e;"));
}

const char* kAtomicsHead =
    "RWByteAddressBuffer counters : register(u0);\n"
    "[numthreads(64, 1, 1)] void C(uint3 id : SV_DispatchThreadID) {\n"
    "  uint previous; int step = 2;\n";

// Builds `source` as a compute pass (entry C) and opens the pack.
PackReader build_compute(const testing::TempDir& dir, const std::string& name, const std::string& source) {
  dir.write(name + "/S.hlsl", source);
  dir.write(name + "/p.pack.json", R"({"name": "p", "passes": [{"name": "P", "source": "S.hlsl", "stages": {"compute": "C"}}]})");
  BuildOptions options;
  options.pack_file = dir / name / "p.pack.json";
  options.output_dir = dir / name / "out";
  options.worker_executable = KILN_WORKER_PATH;
  DiagnosticSink sink;
  EXPECT_TRUE(build_pack(options, sink).ok);
  for (const Diagnostic& d : sink.diagnostics()) ADD_FAILURE() << format_diagnostic(d);
  return PackReader::open(dir / name / "out");
}

// RWByteAddressBuffer's atomics with int arguments (`InterlockedAdd(0, 1)`), which DXC converts to uint: glslang 12
// passed the int and its SPIR-V failed validation, with no line. The SPIR-V of the uint spelling.
TEST(HlslCompat, ByteAddressAtomicsWithIntArgumentsGiveTheSpirvOfTheirUintSpelling) {
  testing::TempDir dir;
  PackReader ints = build_compute(dir, "ints", std::string(kAtomicsHead) +
      "  counters.InterlockedAdd(0, 1, previous);\n  counters . InterlockedMax(4, step);\n"
      "  counters.InterlockedCompareExchange(8, 0, 1, previous);\n  counters.InterlockedOr(12, previous);\n}\n");
  PackReader uints = build_compute(dir, "uints", std::string(kAtomicsHead) +
      "  counters.InterlockedAdd(0, 1u, previous);\n  counters . InterlockedMax(4, (uint)step);\n"
      "  counters.InterlockedCompareExchange(8, 0u, 1u, previous);\n  counters.InterlockedOr(12, previous);\n}\n");
  const SelectedVariant a = ints.select("P", {}), b = uints.select("P", {});
  const StageView* mine = a.stage("compute");
  const StageView* reference = b.stage("compute");
  ASSERT_TRUE(mine && reference);
  EXPECT_EQ(compacted(facts_of(mine->spirv).without_nonuniform), compacted(facts_of(reference->spirv).without_nonuniform));
  EXPECT_EQ(mine->msl, reference->msl);
  // The offset and the original-value output stay as written; RWStructuredBuffer's InterlockedAdd(b[i], 1) is a
  // function, which glslang converts itself.
  EXPECT_EQ(rewrite_byte_address_atomics("b.InterlockedCompareStore(o, 0, v); InterlockedAdd(s[0], 1);"),
            "b.InterlockedCompareStore(o,(uint)( 0),(uint)( v)); InterlockedAdd(s[0], 1);");
  EXPECT_FALSE(rewrite_byte_address_atomics("InterlockedAdd(s[0], 1); x.InterlockedAdd64(0, 1);"));
}

// InterlockedCompareStore, which glslang 12 dropped with only a warning ("unknown glslang aggregate": the shader
// stored nothing): the SPIR-V of InterlockedCompareExchange with the original value unread.
TEST(HlslCompat, CompareStoreGivesTheSpirvOfCompareExchange) {
  testing::TempDir dir;
  const std::string head = "RWByteAddressBuffer counters : register(u0);\nRWStructuredBuffer<uint> flags : register(u1);\n"
                           "[numthreads(64, 1, 1)] void C(uint3 id : SV_DispatchThreadID) {\n";
  PackReader store = build_compute(dir, "store", head +
      "  counters.InterlockedCompareStore(8, 0, id.x);\n  InterlockedCompareStore(flags[id.x], 0u, 1u);\n}\n");
  PackReader exchange = build_compute(dir, "exchange", "static uint kiln_compare_store_original;\n" + head +
      "  counters.InterlockedCompareExchange(8, 0u, id.x, kiln_compare_store_original);\n"
      "  InterlockedCompareExchange(flags[id.x], 0u, 1u, kiln_compare_store_original);\n}\n");
  const SelectedVariant a = store.select("P", {}), b = exchange.select("P", {});
  const StageView* mine = a.stage("compute");
  const StageView* reference = b.stage("compute");
  ASSERT_TRUE(mine && reference);
  EXPECT_EQ(compacted(facts_of(mine->spirv).without_nonuniform), compacted(facts_of(reference->spirv).without_nonuniform));
  EXPECT_NE(mine->msl.find("atomic_compare_exchange"), std::string::npos) << mine->msl;
  EXPECT_EQ(rewrite_compare_store("InterlockedCompareStore(a[0], 1, f(2, 3));"),
            "InterlockedCompareExchange(a[0], 1, f(2, 3), kiln_compare_store_original);");
}

// A texture and a sampler at one binding in different stages clash whether or not combined image samplers are on
// (each stage has only one of them to pair): the advice suggests turning them on only when they are off.
TEST(HlslCompat, AClashsAdviceNeverSuggestsCombinedSamplersWhenTheyAreOn) {
  testing::TempDir dir;
  dir.write("S.hlsl", "Texture2D heights : register(t0);\nTexture2D albedo : register(t1);\nSamplerState linearSampler : register(s0);\n"
                      "float4 V(float4 p : POSITION) : SV_Position { return p + heights.Load(int3(0, 0, 0)); }\n"
                      "float4 F(float4 p : SV_Position) : SV_Target { return albedo.Sample(linearSampler, p.xy); }\n");
  for (const bool combined : {false, true}) {
    dir.write("p.pack.json", std::string(R"({"name": "p", "bindings": {"combined_image_samplers": )") + (combined ? "true" : "false") +
                                 R"(}, "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
    BuildOptions options;
    options.pack_file = dir / "p.pack.json";
    options.output_dir = dir / (combined ? "combined" : "separate");
    options.worker_executable = KILN_WORKER_PATH;
    DiagnosticSink sink;
    EXPECT_FALSE(build_pack(options, sink).ok);
    const std::vector<Diagnostic> diagnostics = sink.diagnostics();
    ASSERT_FALSE(diagnostics.empty());
    EXPECT_EQ(diagnostics.front().id, DiagId::LayoutMismatch) << format_diagnostic(diagnostics.front());
    const std::string text = format_diagnostic(diagnostics.front());
    EXPECT_EQ(text.find("\"combined_image_samplers\": true") != std::string::npos, !combined) << text;
  }
}

// Two stated locations that collide: spirv-val's "conflicting input location assignment", which named no line, is a
// K1401 at the second declaration.
TEST(HlslCompat, CollidingStatedLocationsAreALocatedError) {
  testing::TempDir dir;
  dir.write("S.hlsl", "float4 V(float4 p : POSITION, inout float4 a : TEXCOORD0, inout float4 b : TEXCOORD1) : SV_Position { return p; }\n"
                      "float4 F([[vk::location(0)]] float4 a : TEXCOORD0,\n"
                      "         [[vk::location(0)]] float4 b : TEXCOORD1) : SV_Target { return a + b; }\n");
  dir.write("p.pack.json", R"({"name": "p", "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  BuildOptions options;
  options.pack_file = dir / "p.pack.json";
  options.output_dir = dir / "out";
  options.worker_executable = KILN_WORKER_PATH;
  DiagnosticSink sink;
  EXPECT_FALSE(build_pack(options, sink).ok);
  const std::vector<Diagnostic> diagnostics = sink.diagnostics();
  ASSERT_FALSE(diagnostics.empty());
  const Diagnostic error = diagnostics.front();
  EXPECT_EQ(error.id, DiagId::HlslError) << format_diagnostic(error);
  EXPECT_EQ(error.location.line, 3) << format_diagnostic(error);
  EXPECT_EQ(error.location.column, 16) << format_diagnostic(error);  // the word `location`
  EXPECT_NE(error.message.find("two inputs of this stage are at location 0"), std::string::npos) << format_diagnostic(error);
}

// ---- [[vk::offset]] ---------------------------------------------------------------------------------------------

// The (member name, Offset) pairs of every laid-out struct in a module, by the struct's OpName.
std::map<std::string, std::vector<std::pair<std::string, uint32_t>>> member_offsets_of(std::string_view bytes) {
  std::vector<uint32_t> words(bytes.size() / 4);
  std::memcpy(words.data(), bytes.data(), words.size() * 4);
  std::map<uint32_t, std::string> names;
  std::map<uint32_t, std::map<uint32_t, std::string>> members;
  std::map<uint32_t, std::map<uint32_t, uint32_t>> offsets;
  auto text = [&](size_t at, size_t end) { return std::string(reinterpret_cast<const char*>(&words[at]), (end - at) * 4).c_str(); };
  for (size_t at = 5; at < words.size(); at += words[at] >> 16) {
    const uint32_t count = words[at] >> 16, op = words[at] & 0xffff;
    if (op == 5) names[words[at + 1]] = text(at + 2, at + count);                     // OpName
    if (op == 6) members[words[at + 1]][words[at + 2]] = text(at + 3, at + count);    // OpMemberName
    if (op == 72 && words[at + 3] == 35) offsets[words[at + 1]][words[at + 2]] = words[at + 4];  // Offset
  }
  std::map<std::string, std::vector<std::pair<std::string, uint32_t>>> out;
  for (const auto& [type, by_index] : offsets)
    for (const auto& [index, offset] : by_index) out[names[type]].emplace_back(members[type][index], offset);
  return out;
}

// [[vk::offset]] as DXC users write it: on a cbuffer's members (the SPIR-V of its packoffset spelling), on a first
// member and where HLSL's packing gives the same offset (nothing to do: the SPIR-V of the plain spelling), and on a
// struct's member that it moves by 16 bytes (the members after it move too, as in DXC).
// GL and GL ES cannot state member offsets that std140 does not give (SPIRV-Cross: "cannot be expressed as neither
// std430 nor std140"), whichever spelling states them: packoffset's too.
constexpr const char* kExplicitOffsetTargets = R"(["spirv", "msl"])";

TEST(HlslCompat, MemberOffsetsAreWrittenIntoTheLayout) {
  testing::TempDir dir;
  const std::string vertex = "float4 V(float4 p : POSITION) : SV_Position { return p; }\n";
  const std::string use = "float4 F() : SV_Target { return x * y + tint; }\n";
  PackReader attributed = build_source(dir, "attributed", vertex +
      "cbuffer Material : register(b0) { [[vk::offset(0)]] float4 x; [[vk::offset(16)]] float4 tint;\n"
      "  [[vk::offset(48)]] float y; };\n" + use, kExplicitOffsetTargets);
  PackReader packoffset = build_source(dir, "packoffset", vertex +
      "cbuffer Material : register(b0) { float4 x : packoffset(c0); float4 tint : packoffset(c1);\n"
      "  float y : packoffset(c3); };\n" + use, kExplicitOffsetTargets);
  PackReader same = build_source(dir, "same", vertex +
      "cbuffer Material : register(b0) { [[vk::offset(0)]] float4 x; float4 tint; [[vk::offset(32)]] float y; };\n" + use);
  PackReader plain = build_source(dir, "plain", vertex + "cbuffer Material : register(b0) { float4 x; float4 tint; float y; };\n" + use);
  const SelectedVariant a = attributed.select("P", {}), b = packoffset.select("P", {}), c = same.select("P", {}), d = plain.select("P", {});
  ASSERT_TRUE(a.stage("fragment") && b.stage("fragment") && c.stage("fragment") && d.stage("fragment"));
  EXPECT_EQ(a.stage("fragment")->spirv, b.stage("fragment")->spirv) << "not the SPIR-V of the packoffset spelling";
  EXPECT_EQ(c.stage("fragment")->spirv, d.stage("fragment")->spirv) << "offsets HLSL's packing gives changed the module";
  EXPECT_EQ(member_offsets_of(a.stage("fragment")->spirv).at("Material"),
            (std::vector<std::pair<std::string, uint32_t>>{{"x", 0}, {"tint", 16}, {"y", 48}}));
  // A struct in a ConstantBuffer<T> (glslang names the block after the variable).
  PackReader structure = build_source(dir, "struct", vertex +
      "struct Light { float3 direction; [[vk::offset(32)]] float3 color; float intensity; };\n"
      "ConstantBuffer<Light> light : register(b1);\n"
      "float4 F() : SV_Target { return float4(light.color * light.intensity * light.direction, 1); }\n",
      kExplicitOffsetTargets);
  const SelectedVariant e = structure.select("P", {});
  ASSERT_TRUE(e.stage("fragment"));
  EXPECT_EQ(member_offsets_of(e.stage("fragment")->spirv).at("light"),
            (std::vector<std::pair<std::string, uint32_t>>{{"direction", 0}, {"color", 32}, {"intensity", 44}}));
}

// An offset kiln cannot honour (inside the previous member, or a move that breaks alignment) is a located error,
// never a build with another layout.
TEST(HlslCompat, AnOffsetThatCannotBeHonouredIsALocatedError) {
  testing::TempDir dir;
  for (const auto& [name, member] : {std::pair{"overlap", "[[vk::offset(8)]] float y;"}, std::pair{"unaligned", "[[vk::offset(18)]] float y;"}}) {
    dir.write(std::string(name) + "/S.hlsl", "cbuffer C : register(b0) { float4 x;\n  " + std::string(member) +
                                                 " };\nfloat4 V(float4 p : POSITION) : SV_Position { return p * x * y; }\n"
                                                 "float4 F() : SV_Target { return 1; }\n");
    dir.write(std::string(name) + "/p.pack.json",
              R"({"name": "p", "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
    BuildOptions options;
    options.pack_file = dir / name / "p.pack.json";
    options.output_dir = dir / name / "out";
    options.worker_executable = KILN_WORKER_PATH;
    DiagnosticSink sink;
    EXPECT_FALSE(build_pack(options, sink).ok) << name;
    ASSERT_FALSE(sink.diagnostics().empty()) << name;
    const Diagnostic error = sink.diagnostics().front();
    EXPECT_EQ(error.id, DiagId::HlslError) << format_diagnostic(error);
    EXPECT_EQ(error.location.line, 2) << format_diagnostic(error);
    EXPECT_EQ(error.location.column, 9) << format_diagnostic(error);  // the word `offset`
    EXPECT_NE(error.message.find("cannot be honoured: HLSL's packing puts it at 16"), std::string::npos) << format_diagnostic(error);
  }
}

// ---- names glslang reserves --------------------------------------------------------------------------------------

// A module without its OpName and OpMemberName instructions.
std::vector<uint32_t> without_names(std::string_view bytes) {
  std::vector<uint32_t> words(bytes.size() / 4);
  std::memcpy(words.data(), bytes.data(), words.size() * 4);
  std::vector<uint32_t> out(words.begin(), words.begin() + 5);
  for (size_t at = 5; at < words.size(); at += words[at] >> 16)
    if ((words[at] & 0xffff) != 5 && (words[at] & 0xffff) != 6)
      out.insert(out.end(), words.begin() + static_cast<long>(at), words.begin() + static_cast<long>(at + (words[at] >> 16)));
  return out;
}

// `Texture2D texture; SamplerState sampler;`, which DXC takes and glslang 12 refused ("';' : Expected", no column):
// the module of the same shader with other names, and the reflection keeps the author's.
TEST(HlslCompat, ResourcesNamedWithWordsGlslangReservesKeepTheirNames) {
  testing::TempDir dir;
  const std::string vertex = "float4 V(float4 p : POSITION, inout float2 uv : TEXCOORD0) : SV_Position { return p; }\n";
  auto shader = [&](const std::string& texture, const std::string& sampler) {
    return vertex + "Texture2D " + texture + " : register(t0);\nSamplerState " + sampler + " : register(s1);\n"
           "struct Material { float4 tint; };\n"
           "float4 F(float2 uv : TEXCOORD0) : SV_Target { return " + texture + ".Sample(" + sampler + ", uv); }\n";
  };
  PackReader reserved = build_source(dir, "reserved", shader("texture", "sampler"));
  PackReader plain = build_source(dir, "plain", shader("albedo", "linearSampler"));
  const SelectedVariant a = reserved.select("P", {}), b = plain.select("P", {});
  const StageView* mine = a.stage("fragment");
  const StageView* reference = b.stage("fragment");
  ASSERT_TRUE(mine && reference);
  EXPECT_EQ(without_names(mine->spirv), without_names(reference->spirv));
  ASSERT_EQ(mine->reflection->resources.size(), 2u);
  std::set<std::string> names;
  for (const auto& resource : mine->reflection->resources) names.insert(resource.name);
  EXPECT_EQ(names, (std::set<std::string>{"texture", "sampler"}));
  EXPECT_FALSE(mine->glsl.empty());
  EXPECT_FALSE(mine->msl.empty());
  // A word that is no declared name is left alone (`sampler` as DX9's type, a file named texture.hlsl).
  EXPECT_FALSE(rewrite_reserved_names("#line 1 \"texture.hlsl\"\nsampler s; float4 x = tex2D(s, uv);"));
  EXPECT_EQ(rewrite_reserved_names("#line 1 \"texture.hlsl\"\nTexture2D texture;\nx = texture.Sample(s, uv);"),
            "#line 1 \"texture.hlsl\"\nTexture2D kiln_reserved_texture;\nx = kiln_reserved_texture.Sample(s, uv);");
}

// The index's value is followed into a helper function and through a local variable, as DXC's inlining would:
// every access it selects is decorated, and the rest of the module is the SPIR-V of the plain index. SPIR-V only:
// GL and GL ES have no non-uniform qualifier outside Vulkan GLSL, Metal binds unbounded arrays through argument
// buffers (each a clear K1405, pipeline.HlslCompat.AnUnboundedResourceArrayIsARuntimeDescriptorArray).
const char* kBindlessHead =
    "struct Material { float4 tint; };\n"
    "Texture2D textures[] : register(t0, space1);\n"
    "ConstantBuffer<Material> materials[] : register(b0, space2);\n"
    "SamplerState linearSampler : register(s0);\n"
    "void V(float4 p : POSITION, inout float2 uv : TEXCOORD0, inout uint id : TEXCOORD1, out float4 pos : SV_Position) { pos = p; }\n"
    "float4 Fetch(uint index, float2 uv) { return textures[index].Sample(linearSampler, uv); }\n"
    "float4 F(float2 uv : TEXCOORD0, nointerpolation uint id : TEXCOORD1) : SV_Target {\n";

TEST(HlslCompat, NonUniformResourceIndexDecoratesTheAccessesItSelects) {
  testing::TempDir dir;
  PackReader dxc = build_source(dir, "dxc", std::string(kBindlessHead) +
      "  uint material = NonUniformResourceIndex(id + 1);\n"
      "  return Fetch(NonUniformResourceIndex(id), uv) * materials[material].tint;\n}\n", R"(["spirv"])");
  PackReader plain = build_source(dir, "plain", std::string(kBindlessHead) +
      "  uint material = id + 1;\n"
      "  return Fetch(id, uv) * materials[material].tint;\n}\n", R"(["spirv"])");
  const SelectedVariant a = dxc.select("P", {}), b = plain.select("P", {});
  const SpirvFacts mine = facts_of(a.stage("fragment")->spirv), reference = facts_of(b.stage("fragment")->spirv);
  EXPECT_TRUE(reference.nonuniform.empty());
  EXPECT_FALSE(reference.capabilities.count(kShaderNonUniform));
  EXPECT_TRUE(mine.capabilities.count(kShaderNonUniform));
  EXPECT_TRUE(mine.capabilities.count(kSampledImageArrayNonUniformIndexing));
  EXPECT_TRUE(mine.capabilities.count(kUniformBufferArrayNonUniformIndexing));
  // The texture's access chain, the image loaded through it and the sampled image made of it; the buffer's access
  // chain and the member loaded through it.
  std::multiset<uint32_t> opcodes;
  for (uint32_t id : mine.nonuniform) opcodes.insert(mine.opcode_of.count(id) ? mine.opcode_of.at(id) : 0);
  EXPECT_EQ(opcodes, (std::multiset<uint32_t>{65, 65, 61, 61, 86})) << ::testing::PrintToString(opcodes);
  EXPECT_EQ(compacted(mine.without_nonuniform), compacted(reference.without_nonuniform)) << "not the SPIR-V of the plain index";
}

TEST(HlslCompat, TheNonUniformRewriteKeepsColumnsAndTheTextsOwnFunction) {
  const std::string text = "x = t[NonUniformResourceIndex(i)].Sample(s, uv) + q.NonUniformResourceIndex(j);";
  const std::optional<std::string> rewritten = rewrite_nonuniform_index(text);
  ASSERT_TRUE(rewritten);
  EXPECT_EQ(*rewritten, "x = t[kiln_NonUniformResIndex(i)].Sample(s, uv) + q.NonUniformResourceIndex(j);");
  EXPECT_EQ(rewritten->size(), text.size());
  EXPECT_FALSE(rewrite_nonuniform_index("uint NonUniformResourceIndex(uint i) { return i; }\nx = t[NonUniformResourceIndex(i)];"));
  EXPECT_FALSE(rewrite_nonuniform_index("NonUniformResourceIndexCount = 3;"));
}

// An unbounded resource array is a runtime descriptor array, as in DXC: glslang 12 sized it by the largest
// constant index (1 when indexed dynamically), so the host's descriptor count and every index past it were wrong.
TEST(HlslCompat, AnUnboundedResourceArrayIsARuntimeDescriptorArray) {
  testing::TempDir dir;
  PackReader pack = build_source(dir, "bindless", std::string(kBindlessHead) +
      "  return Fetch(id, uv) * materials[id + 1].tint * textures[3].Sample(linearSampler, uv);\n}\n", R"(["spirv"])");
  const SelectedVariant variant = pack.select("P", {});
  const StageView* fragment = variant.stage("fragment");
  ASSERT_TRUE(fragment);
  std::map<std::string, uint32_t> counts;
  for (const Resource& r : fragment->reflection->resources) counts[r.name] = r.count;
  EXPECT_EQ(counts, (std::map<std::string, uint32_t>{{"linearSampler", 1}, {"materials", 0}, {"textures", 0}}));
  EXPECT_TRUE(facts_of(fragment->spirv).capabilities.count(5302));  // RuntimeDescriptorArray
  // Targets that cannot bind them say so (SPIRV-Cross's MSL writer aborted on them).
  dir.write("bindless/p.pack.json", R"({"name": "p", "targets": ["msl"], "passes": [{"name": "P", "source": "S.hlsl",
      "stages": {"vertex": "V", "fragment": "F"}}]})");
  auto msl = testing::run_kiln({"build", "p.pack.json", "-o", "msl", "--no-cache", "-q"}, dir / "bindless");
  EXPECT_EQ(msl.exit_code, 1);
  EXPECT_NE(msl.err.find("' is an unbounded resource array, which Metal binds only through argument buffers"), std::string::npos)
      << msl.err;
  EXPECT_EQ(msl.err.find("K1501"), std::string::npos) << msl.err;
  // A sized array keeps its size.
  EXPECT_TRUE(unbounded_resource_arrays("Texture2D a[4]; float b[];").empty());
  EXPECT_EQ(unbounded_resource_arrays("Texture2D<float4> a[] : register(t0, space1);\nStructuredBuffer<Light> lights [ ];\n"
                                      "void f() { Texture2D local[]; }"),
            (std::vector<std::string>{"a", "lights"}));
}

// Arrays of structured and byte-address buffers crash glslang 12 (or fail its parse): an error at the declaration.
TEST(HlslCompat, AnArrayOfStructuredBuffersIsAnErrorNotACrash) {
  testing::TempDir dir;
  dir.write("S.hlsl", "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "StructuredBuffer<float4> tints[4] : register(t0, space2);\n"
                      "float4 F(nointerpolation uint id : TEXCOORD1) : SV_Target { return tints[id][0]; }\n");
  dir.write("p.pack.json", R"({"name": "p", "targets": ["spirv"], "passes": [{"name": "P", "source": "S.hlsl",
      "stages": {"fragment": "F"}}]})");
  auto r = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--no-cache", "-q"}, dir.path());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("S.hlsl:2:26: error[K1401]: 'tints' : an array of StructuredBuffer (DXC: a descriptor array of storage "
                       "buffers) is beyond glslang 12, which crashes on an access to it"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("K1501"), std::string::npos) << r.err;
}

// The two declaration scans read the user's whole file: hostile shapes (megabytes of blanks or template text where
// a declaration's parts go, a hundred thousand declarations) end promptly, in one pass, without deep recursion.
TEST(HlslCompat, TheDeclarationScansStayLinearOnHostileText) {
  const std::string blanks(2 << 20, ' ');
  const std::string long_template = "Texture2D<" + std::string(2 << 20, 'a') + "> t[];\n";
  std::string many;
  for (int i = 0; i < 100000; ++i) many += "Texture2D t" + std::to_string(i) + "[]; StructuredBuffer<float4> s" + std::to_string(i) + "[2];\n";
  EXPECT_TRUE(unbounded_resource_arrays("Texture2D" + blanks + "t[];").empty());
  EXPECT_TRUE(unbounded_resource_arrays(long_template).empty());
  EXPECT_EQ(unbounded_resource_arrays(many).size(), 100000u);
  EXPECT_TRUE(check_buffer_arrays_source("StructuredBuffer<" + std::string(2 << 20, 'a') + "> s[2];", "S.hlsl").empty());
  EXPECT_EQ(check_buffer_arrays_source(many, "S.hlsl").size(), 16u);  // a bounded number of errors
  EXPECT_TRUE(check_buffer_arrays_source("void f() { StructuredBuffer<float4> local[2]; }", "S.hlsl").empty());
  // The enum, attribute and atomic rewrites: unclosed bodies, attributes outside any record, unfinished calls.
  std::string enums, offsets, calls;
  for (int i = 0; i < 100000; ++i) {
    enums += "enum E" + std::to_string(i) + " { A,";
    offsets += "[[vk::offset(0)]] float f" + std::to_string(i) + ";";
    calls += "b.InterlockedAdd((1, InterlockedCompareStore((";
  }
  EXPECT_FALSE(rewrite_enums(enums));
  EXPECT_FALSE(strip_member_offsets(offsets));
  EXPECT_FALSE(rewrite_byte_address_atomics(calls));
  EXPECT_FALSE(rewrite_compare_store(calls));
}

// SV_ViewID and SV_ShadingRate are built-ins, as in DXC: glslang 12 made them user inputs with locations, and
// every later location moved (the vertex stage, which does not write them, no longer matched).
TEST(HlslCompat, ViewIdAndShadingRateAreBuiltInsAndLaterLocationsDoNotMove) {
  testing::TempDir dir;
  const std::string vertex = "void V(float4 p : POSITION, inout float2 uv : TEXCOORD0, inout float4 color : COLOR0, "
                             "out float4 pos : SV_Position) { pos = p; }\n";
  // SPIR-V and MSL: GL and GL ES write multiview with GL_OVR_multiview2, which needs the view count (a K1405).
  PackReader builtins = build_source(dir, "builtins", vertex +
      "float4 F(float2 uv : TEXCOORD0, uint view : SV_ViewID, uint rate : SV_ShadingRate, float4 color : COLOR0) : SV_Target {\n"
      "  return color * float(view + rate) + uv.xyxy;\n}\n", R"(["spirv", "msl"])");
  PackReader plain = build_source(dir, "plain", vertex +
      "float4 F(float2 uv : TEXCOORD0, float4 color : COLOR0) : SV_Target { return color * 3.0 + uv.xyxy; }\n",
      R"(["spirv", "msl"])");
  const SelectedVariant a = builtins.select("P", {}), b = plain.select("P", {});
  const StageView* mine = a.stage("fragment");
  const StageView* reference = b.stage("fragment");
  ASSERT_TRUE(mine && reference);
  EXPECT_EQ(mine->reflection->inputs, reference->reflection->inputs);  // uv at 0, color at 1: only the user's inputs
  const SpirvFacts facts = facts_of(mine->spirv);
  EXPECT_TRUE(facts.capabilities.count(4439));  // MultiView
  EXPECT_TRUE(facts.capabilities.count(4422));  // FragmentShadingRateKHR
  EXPECT_TRUE(facts.builtins.count(4440));      // ViewIndex
  EXPECT_TRUE(facts.builtins.count(4444));      // ShadingRateKHR
  EXPECT_FALSE(std::string(mine->msl).empty());
  EXPECT_EQ(std::string(mine->spirv).find("hlsl_functionality1"), std::string::npos);  // glslang's semantics are gone
}

// Beside located inputs (`[[vk::location(N)]]`, which DXC requires of all or none), the built-ins took a location
// that glslang numbered automatically, and moving the later locations down put the second located input onto the
// first ("conflicting input location"); only one located input worked. The stated locations stay as written.
TEST(HlslCompat, ViewIdAndShadingRateLeaveStatedLocationsWhereTheyAre) {
  testing::TempDir dir;
  const std::string vertex =
      "struct VOut { float4 pos : SV_Position; [[vk::location(0)]] float2 uv : TEXCOORD0;\n"
      "  [[vk::location(1)]] float4 color : COLOR0; [[vk::location(2)]] float3 normal : NORMAL; };\n"
      "VOut V([[vk::location(0)]] float4 p : POSITION) { VOut o; o.pos = p; o.uv = p.xy; o.color = p; o.normal = p.xyz; return o; }\n";
  const std::map<std::string, std::pair<std::string, std::string>> cases = {
      {"two", {"uint view : SV_ViewID, [[vk::location(1)]] float4 color : COLOR0, [[vk::location(0)]] float2 uv : TEXCOORD0",
               "[[vk::location(1)]] float4 color : COLOR0, [[vk::location(0)]] float2 uv : TEXCOORD0"}},
      {"three", {"[[vk::location(0)]] float2 uv : TEXCOORD0, uint view : SV_ViewID, [[vk::location(1)]] float4 color : COLOR0,\n"
                 "  uint rate : SV_ShadingRate, [[vk::location(2)]] float3 normal : NORMAL",
                 "[[vk::location(0)]] float2 uv : TEXCOORD0, [[vk::location(1)]] float4 color : COLOR0,\n"
                 "  [[vk::location(2)]] float3 normal : NORMAL"}},
  };
  for (const auto& [name, parameters] : cases) {
    const bool normal = name == "three";
    const std::string use = normal ? " + normal.xyzz" : "";
    PackReader builtins = build_source(dir, name, vertex + "float4 F(" + parameters.first + ") : SV_Target {\n"
        "  return color * float(view" + (normal ? " + rate" : "") + ") + uv.xyxy" + use + ";\n}\n", R"(["spirv", "msl"])");
    PackReader plain = build_source(dir, name + "_plain", vertex + "float4 F(" + parameters.second + ") : SV_Target {\n"
        "  return color * 3.0 + uv.xyxy" + use + ";\n}\n", R"(["spirv", "msl"])");
    const SelectedVariant a = builtins.select("P", {}), b = plain.select("P", {});
    const StageView* mine = a.stage("fragment");
    const StageView* reference = b.stage("fragment");
    ASSERT_TRUE(mine && reference) << name;
    EXPECT_EQ(mine->reflection->inputs, reference->reflection->inputs) << name;
    EXPECT_EQ(mine->reflection->inputs.size(), normal ? 3u : 2u) << name;
    for (const StageVariable& input : mine->reflection->inputs)
      EXPECT_EQ(input.location, input.name == "uv" ? 0u : input.name == "color" ? 1u : 2u) << name << " " << input.name;
    EXPECT_TRUE(facts_of(mine->spirv).builtins.count(4440)) << name;  // ViewIndex
  }
  EXPECT_EQ(explicit_locations("void F([[vk :: location ( 2 ) ]] in float4 a : A, [[vk::location(0)]] nointerpolation uint b[2] : B,\n"
                               "  uint c : C) {}\nstruct S { [[vk::location(7)]] Texture2D<float4> d; };"),
            (std::vector<std::pair<std::string, uint32_t>>{{"a", 2}, {"b", 0}, {"d", 7}}));
}

}  // namespace
}  // namespace kiln
