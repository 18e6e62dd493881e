// SPDX-License-Identifier: Apache-2.0
// The binding model of docs/bindings.md and preprocessor defines, through whole builds: which set and
// binding each resource gets, that the options reach every target and the reflection, and that they are
// part of the no-change check.
#include <gtest/gtest.h>

#include <map>
#include <set>

#include <nlohmann/json.hpp>

#include "kiln/build.hpp"
#include "kiln/pack_reader.hpp"
#include "kiln/manifest_json.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

using nlohmann::json;

using testing::errors_of;

// "name kind set.binding" per resource of a pass's merged layout, in (set, binding) order.
std::string layout_of(const std::filesystem::path& manifest, size_t pass = 0) {
  json m = json::parse(testing::read_file(manifest));
  std::string out;
  for (const json& r : m["passes"][pass]["layout"]["resources"])
    out += (out.empty() ? "" : ", ") + r["name"].get<std::string>() + " " + r["kind"].get<std::string>() + " " +
           r["set"].dump() + "." + r["binding"].dump();
  return out;
}

struct Bindings : ::testing::Test {
  testing::TempDir dir;
  BindingOptions command_line;
  std::vector<Define> defines;
  BuildReport report;

  // A pack of one pass P with entry points V and F in S.hlsl; `pack_fields` adds fields to the pack object.
  void write_pack(const std::string& pack_fields = "", const std::string& pass_fields = "") {
    dir.write("p.pack.json", R"({"name": "p", )" + pack_fields + (pack_fields.empty() ? "" : ", ") +
                                 R"("passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"})" +
                                 (pass_fields.empty() ? "" : ", " + pass_fields) + "}]}");
  }
  bool build(DiagnosticSink& sink, const std::string& out = "out") {
    BuildOptions options;
    options.pack_file = dir / "p.pack.json";
    options.output_dir = dir / out;
    options.cache_dir = dir / "cache";
    options.jobs = 2;
    options.worker_executable = KILN_WORKER_PATH;
    options.bindings = command_line;
    options.defines = defines;
    report = build_pack(options, sink);
    return report.ok;
  }
  std::string layout(const std::string& out = "out") { return layout_of(dir / out / "p.manifest.json"); }
};

// The D3D way: one register number per class. Without shifts every class starts at binding 0.
const char* kD3DRegisters =
    "cbuffer PerFrame : register(b0) { float4x4 viewProj; };\n"
    "Texture2D albedo : register(t0);\n"
    "SamplerState albedoSampler : register(s0);\n"
    "float4 V(float4 p : POSITION) : SV_Position { return mul(viewProj, p); }\n"
    "float4 F(float4 p : SV_Position) : SV_Target { return albedo.Sample(albedoSampler, p.xy); }\n";

TEST_F(Bindings, RegisterClassesCollideWithoutShiftsAndSeparateWithThem) {
  dir.write("S.hlsl", kD3DRegisters);
  write_pack();
  DiagnosticSink plain;
  EXPECT_FALSE(build(plain));
  EXPECT_TRUE(plain.contains(DiagId::LayoutMismatch)) << errors_of(plain);

  write_pack(R"("bindings": {"shifts": [{"register": "t", "shift": 16}, {"register": "s", "shift": 32, "space": 0}]})");
  DiagnosticSink shifted;
  ASSERT_TRUE(build(shifted)) << errors_of(shifted);
  EXPECT_EQ(layout(), "PerFrame uniform_buffer 0.0, albedo texture 0.16, albedoSampler sampler 0.32");
}

TEST_F(Bindings, ShiftsOnTheCommandLineOverrideThePackAndRebuild) {
  dir.write("S.hlsl", kD3DRegisters);
  write_pack(R"("bindings": {"shifts": [{"register": "t", "shift": 16}, {"register": "s", "shift": 32}]})");
  DiagnosticSink first;
  ASSERT_TRUE(build(first)) << errors_of(first);
  command_line.shifts[{RegisterClass::T, 0}] = 8;  // a space's own shift wins over the pack's "all"
  DiagnosticSink second;
  ASSERT_TRUE(build(second)) << errors_of(second);
  EXPECT_FALSE(report.up_to_date);
  EXPECT_EQ(layout(), "PerFrame uniform_buffer 0.0, albedo texture 0.8, albedoSampler sampler 0.32");
  DiagnosticSink third;
  ASSERT_TRUE(build(third)) << errors_of(third);
  EXPECT_TRUE(report.up_to_date);
  command_line = {};
  DiagnosticSink fourth;
  ASSERT_TRUE(build(fourth)) << errors_of(fourth);
  EXPECT_FALSE(report.up_to_date);
  EXPECT_EQ(layout(), "PerFrame uniform_buffer 0.0, albedo texture 0.16, albedoSampler sampler 0.32");
}

TEST_F(Bindings, VkBindingIsNeverShiftedAndRegisterSpaceIsTheSet) {
  dir.write("S.hlsl",
            "[[vk::binding(3, 2)]] cbuffer Pinned : register(b0) { float4 a; };\n"
            "[[vk::binding(5)]] Texture2D pinnedTexture : register(t0, space1);\n"
            "Texture2D spaced : register(t1, space1);\n"
            "SamplerState s : register(s0, space1);\n"
            "float4 V(float4 p : POSITION) : SV_Position { return p + a; }\n"
            "float4 F(float4 p : SV_Position) : SV_Target { return pinnedTexture.Sample(s, p.xy) + spaced.Sample(s, p.xy); }\n");
  write_pack(R"("bindings": {"shifts": [{"register": "b", "shift": 100}, {"register": "t", "shift": 10},
                                        {"register": "t", "shift": 20, "space": 1}, {"register": "s", "shift": 30}]})");
  DiagnosticSink sink;
  ASSERT_TRUE(build(sink)) << errors_of(sink);
  EXPECT_EQ(layout(), "pinnedTexture texture 0.5, spaced texture 1.21, s sampler 1.30, Pinned uniform_buffer 2.3");
}

TEST_F(Bindings, ResourcesWithoutARegisterAreBoundAutomaticallyAboveTheirShift) {
  dir.write("S.hlsl",
            "Texture2D first;\nTexture2D second;\nSamplerState smp;\n"
            "Texture2D fixedTexture : register(t0);\n"
            "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
            "float4 F(float4 p : SV_Position) : SV_Target {\n"
            "  return first.Sample(smp, p.xy) + second.Sample(smp, p.xy) + fixedTexture.Sample(smp, p.xy);\n}\n");
  write_pack(R"("bindings": {"shifts": [{"register": "s", "shift": 8}]})");
  DiagnosticSink sink;
  ASSERT_TRUE(build(sink)) << errors_of(sink);
  EXPECT_EQ(layout(), "fixedTexture texture 0.0, first texture 0.1, second texture 0.2, smp sampler 0.8");

  command_line.auto_bind = false;  // glslang's plain numbering: everything unregistered at 0
  DiagnosticSink off;
  EXPECT_FALSE(build(off));
  EXPECT_TRUE(off.contains(DiagId::LayoutMismatch)) << errors_of(off);
}

TEST_F(Bindings, TheGlobalUniformBlockGoesWhereConfiguredUnshifted) {
  dir.write("S.hlsl",
            "float4 tint;\n"
            "cbuffer PerFrame : register(b0) { float4 offset; };\n"
            "float4 V(float4 p : POSITION) : SV_Position { return p + offset; }\n"
            "float4 F(float4 p : SV_Position) : SV_Target { return tint + offset; }\n");
  write_pack();
  DiagnosticSink automatic;
  ASSERT_TRUE(build(automatic)) << errors_of(automatic);
  EXPECT_EQ(layout(), "PerFrame uniform_buffer 0.0, $Global uniform_buffer 0.1");

  write_pack(R"("bindings": {"shifts": [{"register": "b", "shift": 4}], "global_uniform": {"binding": 2, "set": 1}})");
  DiagnosticSink placed;
  ASSERT_TRUE(build(placed)) << errors_of(placed);
  EXPECT_EQ(layout(), "PerFrame uniform_buffer 0.4, $Global uniform_buffer 1.2");
}

// A texture and a sampler at one register number: one combined binding in SPIR-V, GLSL, MSL and reflection.
TEST_F(Bindings, CombinedModeMakesOneCombinedImageSamplerInEveryTarget) {
  dir.write("S.hlsl",
            "Texture2D albedo : register(t1);\nSamplerState albedoSampler : register(s1);\n"
            "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
            "float4 F(float4 p : SV_Position) : SV_Target { return albedo.Sample(albedoSampler, p.xy); }\n");
  write_pack("", R"("bindings": {"combined_image_samplers": true, "shifts": [{"register": "s", "shift": 40}]})");
  DiagnosticSink sink;
  ASSERT_TRUE(build(sink)) << errors_of(sink);
  EXPECT_EQ(layout(), "albedo combined_image_sampler 0.1");
  PackReader pack = PackReader::open(dir / "out");
  const StageView* fragment = pack.select("P", {}).stage("fragment");
  ASSERT_NE(fragment, nullptr);
  EXPECT_NE(std::string(fragment->glsl).find("uniform sampler2D albedo;"), std::string::npos) << fragment->glsl;
  EXPECT_EQ(std::string(fragment->glsl).find("albedoSampler"), std::string::npos) << fragment->glsl;
  const std::string msl(fragment->msl);
  EXPECT_NE(msl.find("texture2d<float> albedo [[texture(0)]]"), std::string::npos) << msl;
  EXPECT_NE(msl.find("sampler albedoSmplr [[sampler(0)]]"), std::string::npos) << msl;
  // SPIR-V: the sampled-image type, and no separate sampler left.
  const std::string spirv(fragment->spirv);
  const uint32_t sampled_image = (3u << 16) | 27u, sampler = (2u << 16) | 26u;  // OpTypeSampledImage, OpTypeSampler
  auto has_instruction = [&](uint32_t first_word) {
    for (size_t at = 20; at + 4 <= spirv.size(); at += 4)
      if (*reinterpret_cast<const uint32_t*>(spirv.data() + at) == first_word) return true;
    return false;
  };
  EXPECT_TRUE(has_instruction(sampled_image));
  EXPECT_FALSE(has_instruction(sampler));

  write_pack();  // without the mode: a texture and a sampler at one binding is a clash
  DiagnosticSink separate;
  EXPECT_FALSE(build(separate));
  EXPECT_TRUE(separate.contains(DiagId::LayoutMismatch)) << errors_of(separate);
}

// A texture array and one sampler at one register (t0, s0), as samples whose C++ binds a combined-image-sampler array
// write them: one array of combined image samplers, of the array's size, in the reflection and every target; Sample,
// Load and GetDimensions of an element all read it (kiln's own pass, optimize/combine_texture_arrays.cpp: SPIRV-Tools'
// convert-to-sampled-image refuses arrays).
TEST_F(Bindings, CombinedModeMakesATextureArrayAndItsSamplerOneCombinedImageSamplerArray) {
  dir.write("S.hlsl",
            "Texture2D textures[4] : register(t0);\nSamplerState textureSampler : register(s0);\n"
            "cbuffer Material : register(b1) { uint index; };\n"
            "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
            "float4 F(float4 p : SV_Position) : SV_Target {\n"
            "  uint width, height;\n  textures[2].GetDimensions(width, height);\n"
            "  return textures[index].Sample(textureSampler, p.xy / width) + textures[3].Load(int3(p.xy, 0)) * height;\n}\n");
  write_pack("", R"("bindings": {"combined_image_samplers": true})");
  DiagnosticSink sink;
  ASSERT_TRUE(build(sink)) << errors_of(sink);  // validated after the combining, and cross-compiled to every target
  EXPECT_EQ(layout(), "textures combined_image_sampler 0.0, Material uniform_buffer 0.1");
  const json resources = json::parse(testing::read_file(dir / "out/p.manifest.json"))["passes"][0]["layout"]["resources"];
  EXPECT_EQ(resources[0]["count"], 4) << resources.dump();
  PackReader pack = PackReader::open(dir / "out", PackReader::Check::Full);
  const StageView* fragment = pack.select("P", {}).stage("fragment");
  ASSERT_NE(fragment, nullptr);
  ASSERT_NE(fragment->reflection, nullptr);
  size_t combined = 0;
  for (const Resource& resource : fragment->reflection->resources) {
    EXPECT_NE(resource.kind, ResourceKind::Sampler) << resource.name;
    EXPECT_NE(resource.kind, ResourceKind::Texture) << resource.name;
    if (resource.kind != ResourceKind::CombinedImageSampler) continue;
    ++combined;
    EXPECT_EQ(resource.name, "textures");
    EXPECT_EQ(resource.count, 4u);
    EXPECT_EQ(resource.binding, 0u);
  }
  EXPECT_EQ(combined, 1u);
  const std::string glsl(fragment->glsl), gles(fragment->gles), msl(fragment->msl);
  EXPECT_NE(glsl.find("layout(binding = 0) uniform sampler2D textures[4];"), std::string::npos) << glsl;
  EXPECT_NE(glsl.find("texture(textures["), std::string::npos) << glsl;
  EXPECT_NE(glsl.find("texelFetch(textures[3]"), std::string::npos) << glsl;
  EXPECT_NE(glsl.find("textureSize(textures[2]"), std::string::npos) << glsl;
  EXPECT_EQ(glsl.find("textureSampler"), std::string::npos) << glsl;
  EXPECT_NE(gles.find("uniform highp sampler2D textures[4];"), std::string::npos) << gles;
  EXPECT_NE(msl.find("array<texture2d<float>, 4> textures [[texture(0)]]"), std::string::npos) << msl;
  EXPECT_NE(msl.find("array<sampler, 4> texturesSmplr [[sampler(0)]]"), std::string::npos) << msl;
}

// What cannot become one combined-image-sampler array is an error at the declaration that stops it, saying why:
// the sampler also samples another texture, the array is sampled with another sampler as well, the sampler is an
// array.
TEST_F(Bindings, ATextureArrayThatCannotBeCombinedIsALocatedErrorThatSaysWhy) {
  struct Case {
    std::string declarations, sample;
    int line, column;
    std::string because;
  };
  const std::vector<Case> cases = {
      {"Texture2D textures[4] : register(t0);\nTexture2D other : register(t1);\nSamplerState s : register(s0);\n",
       "textures[1].Sample(s, p.xy) + other.Sample(s, p.xy)", 3, 14,
       "'s' : with combined image samplers, the texture array 'textures' and the sampler 's' at set 0 binding 0 become one "
       "array of combined image samplers, but 's' also samples 'other': sample 'other' with another sampler, or give 's' "
       "its own binding (an s shift)"},
      {"Texture2D textures[4] : register(t0);\nSamplerState s : register(s0);\nSamplerState pointSampler : register(s1);\n",
       "textures[1].Sample(s, p.xy) + textures[2].Sample(pointSampler, p.xy)", 1, 11,
       "'textures' : with combined image samplers, the texture array 'textures' and the sampler 's' at set 0 binding 0 "
       "become one array of combined image samplers, but 'textures' is also sampled with 'pointSampler': sample it with 's' "
       "only, or give 's' its own binding (an s shift)"},
      {"Texture2D textures[4] : register(t0);\nSamplerState s[4] : register(s0);\n", "textures[1].Sample(s[1], p.xy)", 2, 14,
       "'s' : with combined image samplers, a texture (or a texture array) and one sampler at a binding become one "
       "combined image sampler, but 's' at set 0 binding 0 is an array of samplers, beside the texture array "
       "'textures': declare one sampler at that register, or give the samplers their own binding (an s shift)"},
  };
  for (const Case& c : cases) {
    dir.write("S.hlsl", c.declarations + "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                                         "float4 F(float4 p : SV_Position) : SV_Target { return " + c.sample + "; }\n");
    write_pack("", R"("bindings": {"combined_image_samplers": true})");
    DiagnosticSink sink;
    EXPECT_FALSE(build(sink));
    const std::vector<Diagnostic> diagnostics = sink.diagnostics();
    ASSERT_FALSE(diagnostics.empty()) << c.sample;
    const Diagnostic& error = diagnostics.front();
    EXPECT_EQ(error.id, DiagId::OptimizerFailed) << format_diagnostic(error);
    EXPECT_EQ(error.message, "combine-image-samplers: " + c.because) << format_diagnostic(error);
    EXPECT_EQ(error.location.line, c.line) << format_diagnostic(error);
    EXPECT_EQ(error.location.column, c.column) << format_diagnostic(error);
  }
}

TEST_F(Bindings, ThePassBindingsAndDefinesAreInTheManifest) {
  dir.write("S.hlsl", kD3DRegisters);
  write_pack(R"("bindings": {"shifts": [{"register": "t", "shift": 16}]}, "defines": {"QUALITY": 2})",
             R"("bindings": {"shifts": [{"register": "s", "shift": 32}]}, "defines": {"FAST": true})");
  DiagnosticSink sink;
  ASSERT_TRUE(build(sink)) << errors_of(sink);
  json pass = json::parse(testing::read_file(dir / "out/p.manifest.json"))["passes"][0];
  EXPECT_EQ(pass["bindings"], "-fvk-t-shift 16 all -fvk-s-shift 32 all");
  EXPECT_EQ(pass["defines"], json({{"FAST", "1"}, {"QUALITY", "2"}}));
}

// Defines ---------------------------------------------------------------------------------------------

const char* kDefined =
    "#ifndef LEVEL\n#define LEVEL 1\n#endif\n"
    "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
    "float4 F() : SV_Target { return float4(LEVEL * 0.125, 0, 0, 1); }\n";

std::string fragment_glsl(const std::filesystem::path& out) {
  PackReader pack = PackReader::open(out);
  return std::string(pack.select("P", {}).stage("fragment")->glsl);
}

TEST_F(Bindings, ADefineInThePackChangesTheOutputAndThePassValueWins) {
  dir.write("S.hlsl", kDefined);
  write_pack();
  DiagnosticSink none;
  ASSERT_TRUE(build(none, "none")) << errors_of(none);
  write_pack(R"("defines": {"LEVEL": 4})");
  DiagnosticSink pack;
  ASSERT_TRUE(build(pack, "pack")) << errors_of(pack);
  write_pack(R"("defines": {"LEVEL": 4})", R"("defines": {"LEVEL": "6"})");
  DiagnosticSink pass;
  ASSERT_TRUE(build(pass, "pass")) << errors_of(pass);
  EXPECT_NE(fragment_glsl(dir / "none").find("0.125"), std::string::npos) << fragment_glsl(dir / "none");
  EXPECT_NE(fragment_glsl(dir / "pack").find("0.5"), std::string::npos) << fragment_glsl(dir / "pack");
  EXPECT_NE(fragment_glsl(dir / "pass").find("0.75"), std::string::npos) << fragment_glsl(dir / "pass");
}

TEST_F(Bindings, ChangingADefineOnTheCommandLineRebuilds) {
  dir.write("S.hlsl", kDefined);
  write_pack(R"("defines": {"LEVEL": 4})");
  DiagnosticSink first;
  ASSERT_TRUE(build(first)) << errors_of(first);
  defines = {{"LEVEL", "2"}};  // the command line wins over the pack
  DiagnosticSink second;
  ASSERT_TRUE(build(second)) << errors_of(second);
  EXPECT_FALSE(report.up_to_date);
  EXPECT_NE(fragment_glsl(dir / "out").find("0.25"), std::string::npos) << fragment_glsl(dir / "out");
  DiagnosticSink third;
  ASSERT_TRUE(build(third)) << errors_of(third);
  EXPECT_TRUE(report.up_to_date);
  defines = {{"LEVEL", "8"}};
  DiagnosticSink fourth;
  ASSERT_TRUE(build(fourth)) << errors_of(fourth);
  EXPECT_FALSE(report.up_to_date);
  EXPECT_NE(fragment_glsl(dir / "out").find("1.0"), std::string::npos) << fragment_glsl(dir / "out");
}

TEST_F(Bindings, ADefineThatIsNotAnIdentifierInThePackIsAnError) {
  dir.write("S.hlsl", kDefined);
  write_pack(R"("defines": {"2FAST": 1})");
  DiagnosticSink sink;
  EXPECT_FALSE(build(sink));
  EXPECT_EQ(errors_of(sink), (dir / "p.pack.json").string() +
                                 ":1:28: error[K1011]: define: '2FAST' is not a preprocessor identifier: letters, digits and '_', "
                                 "not starting with a digit\n"
                                 "    {\"name\": \"p\", \"defines\": {\"2FAST\": 1}, \"passes\": [{\"name\": \"P\", \"source\": "
                                 "\"S.hlsl\", \"stages\": {\"vertex\": \"V\", \"fragment\": \"F\"}}]}\n"
                                 "                               ^\n");
}

TEST_F(Bindings, ADefineValueEndingInABackslashInThePackIsAnError) {
  dir.write("S.hlsl", kDefined);
  write_pack(R"("defines": {"DIR": "C:\\shaders\\"})");
  DiagnosticSink sink;
  EXPECT_FALSE(build(sink));
  EXPECT_NE(errors_of(sink).find(":1:28: error[K1011]: define: the value of 'DIR' ends in a backslash, which would "
                                 "continue the #define onto the next line and swallow it\n"),
            std::string::npos)
      << errors_of(sink);
}

// Shifts, spaces and the $Global binding near 2^32 wrapped to bindings 0 and 1; the pack now has the command line's
// limit (kMaxBindingNumber).
TEST_F(Bindings, AShiftAboveTheLimitInThePackIsAnError) {
  dir.write("S.hlsl", kDefined);
  write_pack(R"("bindings": {"shifts": [{"register": "t", "shift": 4294967295}]})");
  DiagnosticSink sink;
  EXPECT_FALSE(build(sink));
  EXPECT_NE(errors_of(sink).find("error[K1011]: a shift needs \"shift\": a non-negative integer up to 999999999\n"),
            std::string::npos)
      << errors_of(sink);
  write_pack(R"("bindings": {"global_uniform": {"binding": 4294967295}})");
  DiagnosticSink global;
  EXPECT_FALSE(build(global));
  EXPECT_NE(errors_of(global).find("each a non-negative integer up to 999999999)"), std::string::npos) << errors_of(global);
}

// Each reflected kind is one Vulkan descriptor type: a Buffer<T> is a uniform texel buffer and a RWBuffer<T> a storage
// texel buffer (they were `texture` and `storage_image` with dimension "Buffer", which a loader took for images), in
// the stage's reflection, the pass layout, the runtime index and the MSL records.
TEST_F(Bindings, TexelBuffersHaveKindsOfTheirOwn) {
  dir.write("S.hlsl",
            "Buffer<float4> offsets : register(t0);\nRWBuffer<uint> counts : register(u1);\nTexture2D albedo : register(t2);\n"
            "RWTexture2D<float4> target : register(u3);\n"
            "float4 V(float4 p : POSITION, uint i : SV_InstanceID) : SV_Position { return p + offsets.Load(i); }\n"
            "float4 F(float4 p : SV_Position) : SV_Target {\n"
            "  InterlockedAdd(counts[uint(p.x) & 63u], 1u);\n  target[uint2(p.xy)] = p;\n"
            "  return albedo.Load(int3(p.xy, 0)) + offsets[1];\n}\n");
  write_pack(R"("targets": ["spirv", "msl"])");
  DiagnosticSink sink;
  ASSERT_TRUE(build(sink)) << errors_of(sink);
  EXPECT_EQ(layout(), "offsets uniform_texel_buffer 0.0, counts storage_texel_buffer 0.1, albedo texture 0.2, "
                      "target storage_image 0.3");
  PackReader pack = PackReader::open(dir / "out");  // the reflections as the runtime index carries them
  const StageView* fragment = pack.select("P", {}).stage("fragment");
  ASSERT_NE(fragment, nullptr);
  std::map<std::string, std::pair<ResourceKind, std::string>> kinds;
  for (const Resource& r : fragment->reflection->resources) kinds[r.name] = {r.kind, r.dimension};
  EXPECT_EQ(kinds, (std::map<std::string, std::pair<ResourceKind, std::string>>{
                       {"albedo", {ResourceKind::Texture, "2D"}},
                       {"counts", {ResourceKind::StorageTexelBuffer, ""}},
                       {"offsets", {ResourceKind::UniformTexelBuffer, ""}},
                       {"target", {ResourceKind::StorageImage, "2D"}}}));
  // Metal binds every one of them at a texture index, the written ones too.
  std::set<std::string> msl;
  for (const MslResource& r : fragment->reflection->msl->resources)
    if (r.kind == MslResourceKind::Texture) msl.insert(r.name);
  EXPECT_EQ(msl, (std::set<std::string>{"albedo", "counts", "offsets", "target"}));
}

// SubpassInput and SubpassInputMS are input attachments with their index, in the reflection, the pass layout and
// every target's records (GL and GL ES read them as a sampler of their own name at gl_FragCoord; Metal as a
// texture). They were in no record at all, so a loader building descriptor set layouts from the reflection missed
// them. An attribute list (`[[vk::input_attachment_index(2), vk::binding(5)]]`, which glslang 12 refuses) gives
// what the two attributes give apart.
TEST_F(Bindings, InputAttachmentsAreReflectedWithTheirIndexInEveryTarget) {
  dir.write("S.hlsl",
            "[[vk::input_attachment_index(0)]] SubpassInput<float4> albedo : register(t0);\n"
            "[[vk::input_attachment_index(2), vk::binding(5)]] SubpassInputMS<float4> normals;\n"
            "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
            "float4 F() : SV_Target { return albedo.SubpassLoad() + normals.SubpassLoad(1); }\n");
  write_pack();
  DiagnosticSink sink;
  ASSERT_TRUE(build(sink)) << errors_of(sink);
  ASSERT_EQ(layout(), "albedo input_attachment 0.0, normals input_attachment 0.5");
  const json manifest = json::parse(testing::read_file(dir / "out" / "p.manifest.json"));
  EXPECT_EQ(manifest["passes"][0]["layout"]["resources"][1]["input_attachment_index"], 2);
  PackReader pack = PackReader::open(dir / "out");
  const StageView* fragment = pack.select("P", {}).stage("fragment");
  ASSERT_NE(fragment, nullptr);
  std::map<std::string, uint32_t> indices;
  for (const Resource& r : fragment->reflection->resources) {
    EXPECT_EQ(r.kind, ResourceKind::InputAttachment) << r.name;
    indices[r.name] = r.input_attachment_index;
  }
  EXPECT_EQ(indices, (std::map<std::string, uint32_t>{{"albedo", 0}, {"normals", 2}}));
  for (bool es : {false, true}) {
    const GlBindings* gl = fragment->reflection->gl(es);
    ASSERT_NE(gl, nullptr);
    std::map<std::string, uint32_t> samplers;
    for (const GlCombinedSampler& s : gl->combined_image_samplers) {
      EXPECT_EQ(s.texture, s.name);
      EXPECT_EQ(s.sampler, "");
      samplers[s.name] = s.binding;
    }
    EXPECT_EQ(samplers, (std::map<std::string, uint32_t>{{"albedo", 0}, {"normals", 5}})) << (es ? "GL ES" : "GL");
  }
  const std::string glsl(fragment->glsl);
  EXPECT_NE(glsl.find("uniform sampler2D albedo;"), std::string::npos) << glsl;
  std::set<std::string> msl;
  for (const MslResource& r : fragment->reflection->msl->resources)
    if (r.kind == MslResourceKind::Texture) msl.insert(r.name);
  EXPECT_EQ(msl, (std::set<std::string>{"albedo", "normals"}));
}

}  // namespace
}  // namespace kiln
