// SPDX-License-Identifier: Apache-2.0
// The back-end stages on their own, in process, on modules glslang makes from small HLSL: optimize
// (legalize, validate, optimize), reflect (and the pass layout merge), and the 16-bit widening for GL.
#include <gtest/gtest.h>

#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <set>

#include "coverage/instrument.hpp"
#include "cross/targets.hpp"
#include "kiln/coverage_map.hpp"
#include "cross/widen_float16.hpp"
#include "kiln/build.hpp"
#include "frontend/frontend.hpp"
#include "optimize/spirv_tools.hpp"
#include "reflect/reflect.hpp"

namespace kiln {
namespace {

// The front end's module (not legal yet).
std::vector<uint32_t> front_end(const std::string& source, Stage stage, const std::string& entry, bool debug_info = false) {
  std::unique_ptr<Frontend> frontend = make_glslang_frontend();
  CompileResult compiled = frontend->compile({stage, entry, "test.hlsl", source, BindingOptions{}, debug_info});
  EXPECT_TRUE(compiled.ok) << source << (compiled.messages.empty() ? "" : compiled.messages.front().text);
  return compiled.spirv;
}

std::vector<uint32_t> optimized(const std::string& source, Stage stage = Stage::Fragment, const std::string& entry = "F") {
  SpirvResult result = legalize_validate_optimize(front_end(source, stage, entry), true);
  EXPECT_TRUE(result) << (result.error().messages.empty() ? "" : result.error().messages.front());
  return result ? result->spirv : std::vector<uint32_t>();
}

size_t count_opcode(const std::vector<uint32_t>& spirv, uint32_t opcode) {
  size_t n = 0;
  for (size_t i = 5; i < spirv.size() && (spirv[i] >> 16) > 0; i += spirv[i] >> 16)
    if ((spirv[i] & 0xffff) == opcode) ++n;
  return n;
}

// ---- optimize -------------------------------------------------------------------------------------------------

const char* kLoopy = R"(
cbuffer C : register(b0) { float4 tint; int count; };
float4 Scale(float4 v, float s) { return v * s; }
float4 F() : SV_Target {
  float4 sum = 0;
  [unroll] for (int i = 0; i < 4; ++i) sum += Scale(tint, 0.25);
  float unused = tint.x * 3.0;
  return sum;
}
)";

TEST(Optimize, LegalizesValidatesAndOptimizesDeterministically) {
  const std::vector<uint32_t> module = front_end(kLoopy, Stage::Fragment, "F");
  SpirvResult plain = legalize_validate_optimize(module, false);
  SpirvResult fast = legalize_validate_optimize(module, true);
  ASSERT_TRUE(plain && fast);
  EXPECT_FALSE(fast->full_legalization);  // kiln's core recipe suffices for plain HLSL
  // The performance recipe inlined Scale and removed the dead code: fewer functions and instructions.
  constexpr uint32_t kOpFunction = 54;
  EXPECT_EQ(count_opcode(fast->spirv, kOpFunction), 1u);
  EXPECT_LT(fast->spirv.size(), plain->spirv.size());
  EXPECT_TRUE(validate_spirv(fast->spirv));
  EXPECT_EQ(legalize_validate_optimize(module, true)->spirv, fast->spirv);  // the same bytes every time
}

TEST(Optimize, NamesTheStepThatFailed) {
  std::vector<uint32_t> module = front_end(kLoopy, Stage::Fragment, "F");
  module[0] = 0xdeadbeef;  // not SPIR-V
  SpirvResult result = legalize_validate_optimize(module, true);
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error().step, CompileStep::Legalize);
  EXPECT_FALSE(result.error().messages.empty());

  // A module that parses but is invalid fails validation, not the optimizer.
  Result<void, SpirvFailure> invalid = validate_spirv({0x07230203, 0x00010300, 0, 1, 0});
  ASSERT_FALSE(invalid);
  EXPECT_EQ(invalid.error().step, CompileStep::Validate);
  EXPECT_FALSE(invalid.error().messages.empty());
}

// ---- coverage -------------------------------------------------------------------------------------------------

// Line numbers matter below: the branch bodies are on lines 5 and 7, the code after the branch on line 9.
const char* kBranchy = R"(cbuffer C : register(b0) { float4 tint; float cut; };
float4 F(float4 position : SV_Position) : SV_Target {
  float4 c = tint;
  if (position.x > cut) {
    c = c * 2.0;
  } else {
    c = c.yzwx;
  }
  return c + 0.5;
}
)";

// A -g module as kiln build --coverage has it before instrumenting: legalized, not optimized.
std::vector<uint32_t> debug_module(const char* source, Stage stage, const std::string& entry) {
  SpirvResult legal = legalize_validate_optimize(front_end(source, stage, entry, /*debug_info=*/true), false);
  EXPECT_TRUE(legal) << (legal ? "" : legal.error().messages.front());
  return legal ? legal->spirv : std::vector<uint32_t>();
}

std::string_view bytes_of(const std::vector<uint32_t>& words) {
  return {reinterpret_cast<const char*>(words.data()), words.size() * 4};
}

TEST(Coverage, EveryBlockWithLinesGetsAWordThatMapsBackToItsHlslLines) {
  const std::vector<uint32_t> plain = debug_module(kBranchy, Stage::Fragment, "F");
  Result<InstrumentedModule> instrumented = instrument_coverage(plain);
  ASSERT_TRUE(instrumented) << instrumented.error().message;
  EXPECT_TRUE(validate_spirv(instrumented->spirv));
  Result<std::optional<CoverageMap>> map = read_coverage_map(bytes_of(instrumented->spirv));
  ASSERT_TRUE(map) << map.error().message;
  ASSERT_TRUE(*map);
  ASSERT_EQ((*map)->probes.size(), instrumented->probes);
  ASSERT_EQ((*map)->files, std::vector<std::string>{"test.hlsl"});
  // The two branches and what follows them are blocks of their own: each line in one probe, the fragment
  // stage's slot of distinct words.
  auto probe_of = [&](uint32_t line) {
    std::vector<size_t> found;
    for (size_t p = 0; p < (*map)->probes.size(); ++p)
      for (const auto& [file, l] : (*map)->probes[p].lines)
        if (l == line) found.push_back(p);
    return found;
  };
  ASSERT_EQ(probe_of(5).size(), 1u);
  ASSERT_EQ(probe_of(7).size(), 1u);
  ASSERT_EQ(probe_of(9).size(), 1u);
  EXPECT_NE(probe_of(5), probe_of(7));
  EXPECT_NE(probe_of(5), probe_of(9));
  std::set<uint32_t> words;
  for (const CoverageProbe& probe : (*map)->probes) {
    EXPECT_EQ(probe.word % kCoverageStageSlots, 4u);  // spv::ExecutionModelFragment
    words.insert(probe.word);
  }
  EXPECT_EQ(words.size(), (*map)->probes.size());

  // The buffer is a storage buffer of the module's layout, bound by its name like any other resource.
  Reflection reflection = reflect_spirv(instrumented->spirv);
  auto buffer = std::find_if(reflection.resources.begin(), reflection.resources.end(),
                             [](const Resource& r) { return r.name == kCoverageBufferName; });
  ASSERT_NE(buffer, reflection.resources.end());
  EXPECT_EQ(buffer->kind, ResourceKind::StorageBuffer);
  EXPECT_EQ(buffer->set, kCoverageSet);
  EXPECT_EQ(buffer->binding, kCoverageBinding);

  // The fragment shader tests depth first (its probes count fragments that pass it, and hidden ones cost nothing),
  // unless it decides the depth test itself (discard).
  auto early_fragment_tests = [](const std::vector<uint32_t>& spirv) {
    constexpr uint32_t kOpExecutionMode = 16, kEarlyFragmentTests = 9;
    size_t n = 0;
    for (size_t i = 5; i < spirv.size() && (spirv[i] >> 16) > 0; i += spirv[i] >> 16)
      n += (spirv[i] & 0xffff) == kOpExecutionMode && spirv[i + 2] == kEarlyFragmentTests;
    return n;
  };
  EXPECT_EQ(early_fragment_tests(plain), 0u);
  EXPECT_EQ(early_fragment_tests(instrumented->spirv), 1u);
  Result<InstrumentedModule> discarding = instrument_coverage(debug_module(
      "float4 F(float4 p : SV_Position) : SV_Target {\n  if (p.x > 3.0)\n    discard;\n  return p;\n}\n", Stage::Fragment, "F"));
  ASSERT_TRUE(discarding) << discarding.error().message;
  EXPECT_TRUE(validate_spirv(discarding->spirv));
  EXPECT_EQ(early_fragment_tests(discarding->spirv), 0u);

  // A module without the buffer has no map; a vertex stage writes its own slot.
  EXPECT_FALSE(*read_coverage_map(bytes_of(plain)));
  Result<InstrumentedModule> vertex = instrument_coverage(debug_module(
      "float4 V(float4 p : POSITION) : SV_Position {\n  return p * 2.0;\n}\n", Stage::Vertex, "V"));
  ASSERT_TRUE(vertex);
  Result<std::optional<CoverageMap>> vertex_map = read_coverage_map(bytes_of(vertex->spirv));
  ASSERT_TRUE(vertex_map && *vertex_map && !(*vertex_map)->probes.empty());
  for (const CoverageProbe& probe : (*vertex_map)->probes) EXPECT_EQ(probe.word % kCoverageStageSlots, 0u);
}

TEST(Coverage, RefusesAModuleThatBindsTheBuffersPlaceAndReadsHostileMapsAsErrors) {
  Result<InstrumentedModule> taken = instrument_coverage(debug_module(R"(
[[vk::binding(63, 0)]] RWStructuredBuffer<uint> mine;
float4 F() : SV_Target { mine[0] = 1; return 0; }
)", Stage::Fragment, "F"));
  ASSERT_FALSE(taken);
  EXPECT_NE(taken.error().message.find("is taken by 'mine'"), std::string::npos) << taken.error().message;

  Result<InstrumentedModule> instrumented = instrument_coverage(debug_module(kBranchy, Stage::Fragment, "F"));
  ASSERT_TRUE(instrumented);
  std::vector<uint32_t> words = instrumented->spirv;
  EXPECT_FALSE(instrument_coverage(words)) << "instrumented twice";
  EXPECT_FALSE(read_coverage_map(bytes_of(words).substr(0, words.size() * 4 - 2)));  // not whole words
  std::vector<uint32_t> overlong = words;
  overlong[5] |= 0xffffu << 16;  // the first instruction claims more words than the module has
  EXPECT_FALSE(read_coverage_map(bytes_of(overlong)));
  // A probe word past the buffer: every OpConstant the stores index with, made huge.
  Result<std::optional<CoverageMap>> map = read_coverage_map(bytes_of(words));
  ASSERT_TRUE(map && *map);
  constexpr uint32_t kOpConstant = 43;
  for (size_t i = 5; i < words.size(); i += words[i] >> 16)
    if ((words[i] & 0xffff) == kOpConstant && (words[i] >> 16) == 4 && words[i + 3] == (*map)->probes.front().word)
      words[i + 3] = kCoverageBufferWords;
  Result<std::optional<CoverageMap>> past = read_coverage_map(bytes_of(words));
  ASSERT_FALSE(past);
  EXPECT_NE(past.error().message.find("past the buffer"), std::string::npos) << past.error().message;
}

// A hand-made coverage module: the buffer's name and place, OpString "f.hlsl" (id 1), one function of one block
// with `lines` OpLines (each a line of its own) then `stores` coverage stores through one access chain into word 8.
// `extra` is inserted after the header.
std::vector<uint32_t> coverage_module(uint32_t lines, uint32_t stores, const std::vector<uint32_t>& extra = {}) {
  constexpr uint32_t kOpName = 5, kOpString = 7, kOpLine = 8, kOpConstant = 43, kOpFunction = 54, kOpStore = 62,
                     kOpAccessChain = 65, kOpDecorate = 71, kOpLabel = 248, kDescriptorSet = 34, kBinding = 33;
  auto op = [](uint32_t code, uint32_t count) { return (count << 16) | code; };
  auto text = [](std::string_view s) {  // a literal string: NUL-terminated, little-endian, padded to a word
    std::vector<uint32_t> out((s.size() + 4) / 4, 0);
    for (size_t i = 0; i < s.size(); ++i) out[i / 4] |= uint32_t{static_cast<unsigned char>(s[i])} << (8 * (i % 4));
    return out;
  };
  std::vector<uint32_t> m = {0x07230203, 0x10000, 0, 100, 0};
  m.insert(m.end(), extra.begin(), extra.end());
  const std::vector<uint32_t> file = text("f.hlsl"), name = text(kCoverageBufferName);
  m.push_back(op(kOpString, 2 + static_cast<uint32_t>(file.size())));
  m.push_back(1);
  m.insert(m.end(), file.begin(), file.end());
  m.push_back(op(kOpName, 2 + static_cast<uint32_t>(name.size())));
  m.push_back(2);
  m.insert(m.end(), name.begin(), name.end());
  m.insert(m.end(), {op(kOpDecorate, 4), 2, kDescriptorSet, kCoverageSet, op(kOpDecorate, 4), 2, kBinding, kCoverageBinding});
  m.insert(m.end(), {op(kOpConstant, 4), 9, 3, 8});                       // %3 = 8, the word
  m.insert(m.end(), {op(kOpFunction, 5), 9, 4, 0, 9, op(kOpLabel, 2), 5});
  for (uint32_t l = 0; l < lines; ++l) m.insert(m.end(), {op(kOpLine, 4), 1, l + 1, 1});
  m.insert(m.end(), {op(kOpAccessChain, 5), 9, 6, 2, 3});                // %6 = &buffer[%3]
  for (uint32_t s = 0; s < stores; ++s) m.insert(m.end(), {op(kOpStore, 3), 6, 3});
  return m;
}

TEST(Coverage, AnOpStringOrOpNameTooShortToHoldItsStringIsAnError) {
  Result<std::optional<CoverageMap>> whole = read_coverage_map(bytes_of(coverage_module(2, 1)));
  ASSERT_TRUE(whole && *whole) << (whole ? "no map" : whole.error().message);
  EXPECT_EQ((*whole)->files, std::vector<std::string>{"f.hlsl"});
  // A word count of 1 made the reader read count - 2 = 4,294,967,295 words from there: past the module.
  for (uint32_t opcode : {7u, 5u})
    for (uint32_t count : {1u, 2u}) {
      std::vector<uint32_t> extra = {(count << 16) | opcode};
      if (count == 2) extra.push_back(1);
      Result<std::optional<CoverageMap>> map = read_coverage_map(bytes_of(coverage_module(2, 1, extra)));
      ASSERT_FALSE(map) << "opcode " << opcode << ", " << count << " words";
      EXPECT_EQ(map.error().message, std::string("an Op") + (opcode == 7 ? "String" : "Name") + " of " +
                                         std::to_string(count) + " words (it needs 3 or more) at word 5");
    }
}

// The child of AMapIsAsLargeAsItsModuleHoweverManyStoresABlockHolds: reads the map under a 2 GiB address-space
// limit and prints its size.
[[noreturn]] void print_map_size_within_limits(const std::vector<uint32_t>& module) {
#if !defined(__SANITIZE_ADDRESS__)  // ASan reserves terabytes of shadow memory: no address-space limit there
  const rlimit limit{uint64_t{2} << 30, uint64_t{2} << 30};
  ::setrlimit(RLIMIT_AS, &limit);
#endif
  Result<std::optional<CoverageMap>> map = read_coverage_map(bytes_of(module));
  size_t lines = 0;
  if (map && *map)
    for (const CoverageProbe& probe : (*map)->probes) lines += probe.lines.size();
  std::fprintf(stderr, "%zu probes, %zu lines, first %zu\n", map && *map ? (*map)->probes.size() : 0, lines,
               map && *map && !(*map)->probes.empty() ? (*map)->probes.front().lines.size() : 0);
  std::_Exit(0);
}

// 20,000 stores in a block of 20,000 lines (a 560 KB module) were 400 million line records, each store a copy of
// the block's lines: std::bad_alloc after 2.5 GB. The map holds each line once, so the reader needs memory in
// proportion to the module; it runs under an address-space limit here so that a regression fails the test, not the
// machine.
TEST(Coverage, AMapIsAsLargeAsItsModuleHoweverManyStoresABlockHolds) {
  const std::vector<uint32_t> module = coverage_module(20000, 20000);
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(print_map_size_within_limits(module), ::testing::ExitedWithCode(0), "20000 probes, 20000 lines, first 20000\n");
}

// ---- reflect --------------------------------------------------------------------------------------------------

const char* kResources = R"(
cbuffer PerFrame : register(b1) { float4x4 viewProj; float4 colors[3]; float scale; };
Texture2D albedo : register(t2);
TextureCube sky : register(t3);
Texture2DArray<float> shadows : register(t4);
SamplerState linearClamp : register(s5);
SamplerComparisonState shadowCompare : register(s6);
StructuredBuffer<float4> lights : register(t7);
RWTexture2D<float4> output : register(u0, space1);
struct PC { float4 offset; };
[[vk::push_constant]] ConstantBuffer<PC> push;
float4 F(float4 position : SV_Position, float2 uv : TEXCOORD1, float3 normal : NORMAL) : SV_Target {
  float4 c = albedo.Sample(linearClamp, uv) + sky.Sample(linearClamp, normal) * colors[2] * scale;
  c += shadows.SampleCmp(shadowCompare, float3(uv, 0), 0.5) + lights[1] + mul(viewProj, push.offset);
  output[uint2(position.xy)] = c;
  return c;
}
)";

TEST(Reflect, ListsResourcesBlocksAndInterfacesInOrder) {
  const Reflection r = reflect_spirv(optimized(kResources));
  std::vector<std::string> order;
  for (const Resource& resource : r.resources)
    order.push_back(std::to_string(resource.set) + "." + std::to_string(resource.binding) + " " + resource.name + " " +
                    std::string(resource_kind_name(resource.kind)) + (resource.dimension.empty() ? "" : " " + resource.dimension));
  EXPECT_EQ(order, (std::vector<std::string>{"0.1 PerFrame uniform_buffer", "0.2 albedo texture 2D", "0.3 sky texture Cube",
                                             "0.4 shadows texture 2DArray", "0.5 linearClamp sampler",
                                             "0.6 shadowCompare sampler", "0.7 lights storage_buffer", "1.0 output storage_image 2D"}));
  const Resource& frame = r.resources[0];
  EXPECT_EQ(frame.size, 64u + 3 * 16 + 4);
  ASSERT_EQ(frame.members.size(), 3u);
  EXPECT_EQ(frame.members[0].name, "viewProj");
  EXPECT_EQ(frame.members[0].type, "float4x4");
  EXPECT_EQ(frame.members[0].size, 64u);
  EXPECT_EQ(frame.members[1].name, "colors");
  EXPECT_EQ(frame.members[1].offset, 64u);
  EXPECT_EQ(frame.members[1].array_stride, 16u);
  EXPECT_EQ(frame.members[1].size, 48u);
  EXPECT_EQ(frame.members[2].offset, 112u);
  EXPECT_EQ(frame.members[2].array_stride, std::nullopt);
  ASSERT_EQ(r.push_constants.size(), 1u);
  EXPECT_EQ(r.push_constants[0].size, 16u);
  // Inputs by location (glslang numbers them in declaration order; SV_Position is a built-in, not listed).
  ASSERT_EQ(r.inputs.size(), 2u);
  EXPECT_EQ(r.inputs[0].name, "uv");
  EXPECT_EQ(r.inputs[1].name, "normal");
  EXPECT_EQ(r.inputs[0].type, "float2");
  EXPECT_LT(r.inputs[0].location, r.inputs[1].location);
  ASSERT_EQ(r.outputs.size(), 1u);
  EXPECT_EQ(r.outputs[0].type, "float4");
  EXPECT_FALSE(r.glsl || r.gles || r.msl);  // the targets' records are the cross stage's
}

Reflection reflect_fragment(const std::string& hlsl) { return reflect_spirv(optimized(hlsl)); }

TEST(Reflect, MergesAPassLayoutByVulkansRuleNotByNames) {
  const Reflection a = reflect_fragment("Texture2D t : register(t0); SamplerState s : register(s1);\n"
                                        "float4 F(float2 uv : TEXCOORD0) : SV_Target { return t.Sample(s, uv); }\n");
  const Reflection b = reflect_fragment("cbuffer K : register(b2) { float4 k; };\n"
                                        "float4 F() : SV_Target { return k; }\n");
  MergedLayout merged = merge_layouts({{Stage::Vertex, &a}, {Stage::Fragment, &b}, {Stage::Vertex, &a}});
  EXPECT_TRUE(merged.clashes.empty());
  ASSERT_EQ(merged.layout.resources.size(), 3u);
  EXPECT_EQ(merged.layout.resources[2].name, "K");
  EXPECT_TRUE(a.holds(merged.layout.resources[0]));
  EXPECT_FALSE(a.holds(merged.layout.resources[2]));

  // One texture by another name in another stage: one descriptor for Vulkan, no clash.
  const Reflection renamed = reflect_fragment("Texture2D u : register(t0); SamplerState s : register(s1);\n"
                                              "float4 F(float2 uv : TEXCOORD0) : SV_Target { return u.Sample(s, uv); }\n");
  EXPECT_TRUE(merge_layouts({{Stage::Vertex, &a}, {Stage::Fragment, &renamed}}).clashes.empty());
  // A buffer, or an array texture, where the texture is: two descriptors at one binding.
  const Reflection buffer = reflect_fragment("cbuffer C : register(b0) { float4 c; };\n"
                                             "float4 F() : SV_Target { return c; }\n");
  const Reflection array = reflect_fragment("Texture2DArray t : register(t0); SamplerState s : register(s1);\n"
                                            "float4 F(float2 uv : TEXCOORD0) : SV_Target { return t.Sample(s, uv.xyx); }\n");
  merged = merge_layouts({{Stage::Vertex, &a}, {Stage::Fragment, &buffer}, {Stage::Fragment, &array}});
  ASSERT_EQ(merged.clashes.size(), 2u);
  EXPECT_EQ(merged.clashes[0].kind, LayoutClash::Kind::SharedSlot);
  EXPECT_EQ(merged.clashes[0].first.name, "t");
  EXPECT_EQ(merged.clashes[0].second.name, "C");
  EXPECT_EQ(merged.clashes[1].second.dimension, "2DArray");

  // A stage's resource at another binding in another variant: moved (a keyword shifted it); in another stage: fine.
  const Reflection moved = reflect_fragment("Texture2D t : register(t9); SamplerState s : register(s1);\n"
                                            "float4 F(float2 uv : TEXCOORD0) : SV_Target { return t.Sample(s, uv); }\n");
  merged = merge_layouts({{Stage::Fragment, &a}, {Stage::Fragment, &moved}});
  ASSERT_EQ(merged.clashes.size(), 1u);
  EXPECT_EQ(merged.clashes[0].kind, LayoutClash::Kind::MovedResource);
  EXPECT_EQ(merged.clashes[0].second.binding, 9u);
  EXPECT_TRUE(merge_layouts({{Stage::Vertex, &a}, {Stage::Fragment, &moved}}).clashes.empty());

  // A block with fewer members in one stage: fine, and the merged block covers both; overlapping members that
  // disagree: a warning's clash.
  const Reflection longer = reflect_fragment("cbuffer K : register(b2) { float4 k; float4 extra; };\n"
                                             "float4 F() : SV_Target { return k + extra; }\n");
  const Reflection split = reflect_fragment("cbuffer K : register(b2) { float2 x; float2 y; };\n"
                                            "float4 F() : SV_Target { return float4(x, y); }\n");
  merged = merge_layouts({{Stage::Vertex, &b}, {Stage::Fragment, &longer}});
  EXPECT_TRUE(merged.clashes.empty());
  ASSERT_EQ(merged.layout.resources.size(), 1u);
  EXPECT_EQ(merged.layout.resources[0].size, 32u);
  EXPECT_EQ(merged.layout.resources[0].members.size(), 2u);
  merged = merge_layouts({{Stage::Vertex, &b}, {Stage::Fragment, &split}});
  ASSERT_EQ(merged.clashes.size(), 1u);
  EXPECT_EQ(merged.clashes[0].kind, LayoutClash::Kind::MemberMismatch);
  EXPECT_EQ(merged.clashes[0].member, "'k' (float4, bytes 0-15) and 'x' (float2, bytes 0-7)");

  // Push constants: one block per stage, merged the same way.
  Reflection push = b, other_push = b, clashing_push = b;
  push.push_constants = {{"P", 16, {{"color", 0, 16, "float4", std::nullopt}}}};
  other_push.push_constants = {{"Q", 32, {{"color", 0, 16, "float4", std::nullopt}, {"scale", 16, 4, "float", std::nullopt}}}};
  clashing_push.push_constants = {{"P", 4, {{"index", 0, 4, "uint", std::nullopt}}}};
  merged = merge_layouts({{Stage::Vertex, &push}, {Stage::Fragment, &other_push}});
  EXPECT_TRUE(merged.clashes.empty());
  ASSERT_EQ(merged.layout.push_constants.size(), 1u);
  EXPECT_EQ(merged.layout.push_constants[0].size, 32u);
  merged = merge_layouts({{Stage::Vertex, &push}, {Stage::Fragment, &clashing_push}});
  ASSERT_EQ(merged.clashes.size(), 1u);
  EXPECT_TRUE(merged.clashes[0].push_constants);
  EXPECT_EQ(merged.clashes[0].kind, LayoutClash::Kind::MemberMismatch);
}

// ---- widen_float16 --------------------------------------------------------------------------------------------

constexpr uint32_t kOpTypeFloat = 22, kOpDecorate = 71, kDecorationRelaxedPrecision = 0;

bool has_float16(const std::vector<uint32_t>& spirv) {
  for (size_t i = 5; i < spirv.size() && (spirv[i] >> 16) > 0; i += spirv[i] >> 16)
    if ((spirv[i] & 0xffff) == kOpTypeFloat && spirv[i + 2] == 16) return true;
  return false;
}

size_t relaxed_decorations(const std::vector<uint32_t>& spirv) {
  size_t n = 0;
  for (size_t i = 5; i < spirv.size() && (spirv[i] >> 16) > 0; i += spirv[i] >> 16)
    if ((spirv[i] & 0xffff) == kOpDecorate && spirv[i + 2] == kDecorationRelaxedPrecision) ++n;
  return n;
}

TEST(WidenFloat16, WidensHalfMathToRelaxedFloatAndStaysValid) {
  const std::vector<uint32_t> module = optimized(R"(
cbuffer C : register(b0) { float exposure; };
half3 Tonemap(half3 c) { return c / (half3(1.0, 1.0, 1.0) + c); }
float4 F(float4 color : COLOR0) : SV_Target { return float4(Tonemap(half3(color.rgb) * (half)exposure), 1); }
)");
  ASSERT_TRUE(has_float16(module));
  Result<Widened> widened = widen_float16_for_gl(module);
  ASSERT_TRUE(widened) << widened.error().message;
  EXPECT_TRUE(widened->changed);
  EXPECT_FALSE(has_float16(widened->spirv));
  EXPECT_GT(relaxed_decorations(widened->spirv), 0u);
  Result<void, SpirvFailure> valid = validate_spirv(widened->spirv);
  EXPECT_TRUE(valid) << valid.error().messages.front();
}

TEST(WidenFloat16, LeavesModulesWithoutHalfOrWithHalfStorageAlone) {
  const std::vector<uint32_t> plain = optimized("float4 F(float4 c : COLOR0) : SV_Target { return c * 2; }\n");
  Result<Widened> unchanged = widen_float16_for_gl(plain);
  ASSERT_TRUE(unchanged);
  EXPECT_FALSE(unchanged->changed);
  EXPECT_EQ(unchanged->spirv, plain);
  EXPECT_FALSE(widen_float16_for_gl({1, 2, 3}).has_value()) << "not a SPIR-V module";

  // A 16-bit stage interface: widening would change what the other stage reads.
  const std::vector<uint32_t> interface = optimized("half4 F(half4 c : COLOR0) : SV_Target { return c * (half)2.0; }\n");
  ASSERT_TRUE(has_float16(interface));
  Result<Widened> kept = widen_float16_for_gl(interface);
  ASSERT_TRUE(kept);
  EXPECT_FALSE(kept->changed);
  EXPECT_FALSE(kept->unchanged_because.empty());
}

// ---- the target registry ---------------------------------------------------------------------------------------

TEST(Targets, EveryTargetButSpirvHasOneBackEndThatTranslatesAndRecords) {
  EXPECT_EQ(target_backend(Target::Spirv), nullptr);
  ManifestOptions options;
  for (const TargetName& name : kTargetNames) {
    if (name.target == Target::Spirv) continue;
    const TargetBackend* backend = target_backend(name.target);
    ASSERT_NE(backend, nullptr) << name.name;
    EXPECT_EQ(backend->target, name.target);
    EXPECT_TRUE(emit_stage_names().count(std::string(name.emit))) << name.emit;
    EXPECT_EQ(step_name(cross_step(name.target)), "cross-" + std::string(name.name));
    EXPECT_EQ(parse_step("cross-" + std::string(name.name)), cross_step(name.target));
    backend->record_options(options);
  }
  EXPECT_EQ(target_backends().size(), kTargetNames.size() - 1);
  EXPECT_EQ(options.glsl_version, 450u);
  EXPECT_EQ(options.gles_version, 310u);
  EXPECT_EQ(options.msl_version, "2.1");

  const std::vector<uint32_t> module = optimized("Texture2D t : register(t0); SamplerState s : register(s1);\n"
                                                 "cbuffer K : register(b2) { float4 k; };\n"
                                                 "float4 F(float2 uv : TEXCOORD0) : SV_Target { return t.Sample(s, uv) * k; }\n");
  CrossModules modules(module);
  Reflection reflection;
  for (const TargetBackend& backend : target_backends()) {
    Result<std::string> result = cross_compile(backend, modules, reflection);
    ASSERT_TRUE(result) << backend.language << ": " << result.error().message;
    EXPECT_FALSE(result->empty());
  }
  ASSERT_TRUE(reflection.glsl && reflection.gles && reflection.msl);
  ASSERT_EQ(reflection.glsl->combined_image_samplers.size(), 1u);
  EXPECT_EQ(reflection.glsl->combined_image_samplers[0].name, "t_s");
  EXPECT_EQ(reflection.glsl->combined_image_samplers[0].binding, 0u);
  EXPECT_EQ(reflection.gles->blocks.at(0).name, "K");
  EXPECT_EQ(reflection.msl->resources.size(), 3u);
}

}  // namespace
}  // namespace kiln
