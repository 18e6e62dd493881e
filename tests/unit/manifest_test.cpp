// SPDX-License-Identifier: Apache-2.0
// The typed manifest (kiln/manifest.hpp): what to_json writes, that from_json reads it back whole, and that
// from_json refuses what kiln does not write with the place of the mistake.
#include <gtest/gtest.h>

#include "kiln/folded_keywords.hpp"
#include "kiln/manifest_json.hpp"
#include "kiln/runtime_index.hpp"

namespace kiln {
namespace {

using nlohmann::json;

Reflection sample_reflection() {
  Reflection r;
  Resource block;
  block.name = "PerFrame";
  block.kind = ResourceKind::UniformBuffer;
  block.binding = 0;
  block.size = 80;
  block.members = {{"viewProj", 0, 64, "float4x4", std::nullopt}, {"tint", 64, 16, "float4[1]", 16}};
  Resource texture;
  texture.name = "_Shadow";
  texture.kind = ResourceKind::Texture;
  texture.binding = 3;
  texture.dimension = "2DArray";
  texture.depth = true;
  Resource sampler;
  sampler.name = "sampler_Linear";
  sampler.kind = ResourceKind::Sampler;
  sampler.set = 1;
  sampler.binding = 4;
  sampler.count = 2;
  r.resources = {block, texture, sampler};
  r.push_constants = {{"Push", 16, {{"scale", 0, 16, "float4", std::nullopt}}}};
  r.inputs = {{"in.var.POSITION", 0, "float3"}, {"in.var.NORMAL", 1, "float3"}};
  r.outputs = {{"out.var.SV_Target", 0, "float4"}};
  r.glsl = GlBindings{{{"_Shadow_sampler_Linear", "_Shadow", "sampler_Linear", 3}}, {{"PerFrame", ResourceKind::UniformBuffer, 0}}};
  r.msl = MslBindings{{{"PerFrame", MslResourceKind::Buffer, 0}, {"_Shadow", MslResourceKind::Texture, 0}}};
  return r;
}

Manifest sample_manifest() {
  Manifest m;
  m.format_version = 3;
  m.name = "p";
  m.kiln_version = "0.1.0";
  m.tools = {"glslang 12", "SPIRV-Tools v2023.2", "C API 0.54.0"};
  m.options.targets = {Target::Spirv, Target::Msl};
  m.options.spirv_env = "vulkan1.1";
  m.options.glsl_version = 450;
  m.options.gles_version = 310;
  m.options.msl_version = "2.1";
  m.inputs_hash = "00ff";
  m.funnel = {4, 3, 2, 4, 2, 2, 2, 2};
  m.constraints = {{"B", {"A"}, {}, {"C"}, "B needs A"}};
  m.materials = {{"glossy", {"A", "B"}}};
  m.scene_features_json = R"({"fog":{"true":["FOG"]}})";
  ManifestPass& pass = m.passes.emplace_back();
  pass.name = "P";
  pass.entry_points = {{Stage::Vertex, "V"}, {Stage::Fragment, "F"}};
  pass.keyword_groups = {{"multi_compile", {"", "A"}, static_cast<StageMask>(stage_bit(Stage::Vertex) | stage_bit(Stage::Fragment))},
                         {"shader_feature_fragment", {"B"}, stage_bit(Stage::Fragment)}};
  pass.layout = {sample_reflection().resources, {}};
  pass.variants = {{{"B"}, {{Stage::Vertex, 0}, {Stage::Fragment, 1}}}, {{"A", "B"}, {{Stage::Vertex, 0}, {Stage::Fragment, 1}}}};
  pass.bindings = "-fvk-t-shift 16 all";
  pass.defines = {{"QUALITY", "2"}};
  m.binaries = {{Stage::Vertex, "V", {{Target::Spirv, 0}, {Target::Msl, 1}}, 0},
                {Stage::Fragment, "F", {{Target::Spirv, 2}, {Target::Msl, 3}}, 0}};
  m.reflections = {sample_reflection()};
  m.archive = {"p.0123456789abcdef.kpack", 1000, "0123456789abcdef", 4};
  return m;
}

// The file format, field by field, for a small reflection: names, optional fields, the off value, stage and
// target keys.
TEST(Manifest, WritesTheFileFormat) {
  const json reflection = sample_reflection();
  EXPECT_EQ(reflection.at("resources").at(0).dump(),
            R"({"binding":0,"count":1,"kind":"uniform_buffer","members":[{"name":"viewProj","offset":0,"size":64,"type":"float4x4"},)"
            R"({"array_stride":16,"name":"tint","offset":64,"size":16,"type":"float4[1]"}],"name":"PerFrame","set":0,"size":80})");
  EXPECT_EQ(reflection.at("resources").at(1).dump(),
            R"({"binding":3,"count":1,"depth":true,"dimension":"2DArray","kind":"texture","name":"_Shadow","set":0})");
  EXPECT_EQ(reflection.at("resources").at(2).dump(), R"({"binding":4,"count":2,"kind":"sampler","name":"sampler_Linear","set":1})");
  EXPECT_EQ(reflection.at("glsl").dump(),
            R"({"blocks":[{"binding":0,"kind":"uniform_buffer","name":"PerFrame"}],"combined_image_samplers":)"
            R"([{"binding":3,"name":"_Shadow_sampler_Linear","sampler":"sampler_Linear","texture":"_Shadow"}]})");
  EXPECT_FALSE(reflection.contains("gles"));
  EXPECT_EQ(reflection.at("msl").at("resources").at(1).dump(), R"({"index":0,"kind":"texture","name":"_Shadow"})");

  const json manifest = sample_manifest();
  EXPECT_EQ(manifest.at("format"), "kiln-pack-manifest");
  const json& pass = manifest.at("passes").at(0);
  EXPECT_EQ(pass.at("keyword_groups").dump(),
            R"([{"pragma":"multi_compile","stages":["vertex","fragment"],"values":["_","A"]},)"
            R"({"pragma":"shader_feature_fragment","stages":["fragment"],"values":["B"]}])");
  EXPECT_EQ(pass.at("stages").dump(), R"({"fragment":"F","vertex":"V"})");
  EXPECT_EQ(pass.at("variants").at(1).dump(), R"({"binaries":{"fragment":1,"vertex":0},"keywords":["A","B"]})");
  EXPECT_EQ(pass.at("defines").dump(), R"({"QUALITY":"2"})");
  EXPECT_EQ(manifest.at("binaries").at(1).dump(), R"({"blobs":{"msl":3,"spirv":2},"entry":"F","reflection":0,"stage":"fragment"})");
  EXPECT_EQ(manifest.at("constraints").dump(), R"([{"excludes":["C"],"keyword":"B","reason":"B needs A","requires":["A"]}])");
  EXPECT_EQ(manifest.at("options").at("targets").dump(), R"(["spirv","msl"])");

  // Empty optional fields are left out, so packs that use none keep their bytes.
  ManifestPass plain;
  const json plain_json = plain;
  EXPECT_FALSE(plain_json.contains("bindings"));
  EXPECT_FALSE(plain_json.contains("defines"));
  EXPECT_EQ(json(ManifestConstraint{"K", {}, {}, {}, ""}).dump(), R"({"keyword":"K"})");
}

TEST(Manifest, ReadsBackWhatItWrites) {
  const Manifest m = sample_manifest();
  const json text = json::parse(json(m).dump(1));
  const Manifest back = text.get<Manifest>();
  EXPECT_EQ(back.passes, m.passes);
  EXPECT_EQ(back.binaries, m.binaries);
  EXPECT_EQ(back.reflections, m.reflections);
  EXPECT_EQ(back.constraints, m.constraints);
  EXPECT_EQ(back.materials, m.materials);
  EXPECT_EQ(back.options, m.options);
  EXPECT_EQ(back.funnel, m.funnel);
  EXPECT_EQ(back.tools, m.tools);
  EXPECT_EQ(back.archive, m.archive);
  EXPECT_EQ(back.scene_features_json, m.scene_features_json);
  EXPECT_EQ(json(back), json(m));
  ASSERT_NE(back.pass("P"), nullptr);
  EXPECT_EQ(back.pass("Q"), nullptr);
  EXPECT_NO_THROW(back.check_indices());
}

// The runtime index is the same records in binary: a reflection with every optional field decodes to itself, the
// index's tables say what the manifest says, and every truncation of either is an IndexError, never a crash.
TEST(Manifest, TheRuntimeIndexHoldsTheSameRecords) {
  Reflection compute = sample_reflection();
  compute.local_size = std::array<uint32_t, 3>{8, 8, 1};
  compute.gles = GlBindings{{}, {{"Lights", ResourceKind::StorageBuffer, 2}}};
  for (const Reflection& r : {sample_reflection(), compute, Reflection{}})
    EXPECT_EQ(runtime::decode_reflection(runtime::encode_reflection(r)), r);

  Manifest m = sample_manifest();
  m.passes[0].variants.push_back({{"A", "UNDECLARED"}, {{Stage::Fragment, 1}}});
  const std::string bytes = runtime::encode(m);
  const runtime::Index index = runtime::Index::decode(bytes, m.archive.blobs);
  ASSERT_EQ(index.declared_keywords, 2u);  // A, B
  ASSERT_EQ(index.keywords.size(), 3u);
  EXPECT_EQ(index.keywords[2], "UNDECLARED");
  ASSERT_EQ(index.passes.size(), 1u);
  const runtime::Pass& pass = index.passes[0];
  EXPECT_EQ(pass.name, "P");
  EXPECT_EQ(pass.entry_points[static_cast<size_t>(Stage::Fragment)], "F");
  EXPECT_EQ(pass.entry_points[static_cast<size_t>(Stage::Compute)], "");
  ASSERT_EQ(pass.group_count, 2u);
  EXPECT_EQ(index.groups[1].pragma, "shader_feature_fragment");
  EXPECT_EQ(index.groups[1].stages, stage_bit(Stage::Fragment));
  EXPECT_EQ(index.values[index.groups[0].first_value], runtime::kOffValue);
  ASSERT_EQ(pass.variant_count, 3u);
  const runtime::Variant& last = index.variants[2];
  EXPECT_EQ(last.keyword_count, 2u);
  EXPECT_EQ(index.keywords[index.variant_keywords[last.first_keyword + 1]], "UNDECLARED");
  EXPECT_EQ(last.binaries[static_cast<size_t>(Stage::Fragment)], 1u);
  EXPECT_EQ(last.binaries[static_cast<size_t>(Stage::Vertex)], runtime::kNone);
  ASSERT_EQ(index.binaries.size(), 2u);
  EXPECT_EQ(index.binaries[1].entry, "F");
  EXPECT_EQ(index.binaries[1].blobs[static_cast<size_t>(Target::Msl)], 3u);
  EXPECT_EQ(index.binaries[1].blobs[static_cast<size_t>(Target::Glsl)], runtime::kNone);
  EXPECT_EQ(runtime::decode_reflection(index.reflections[0]), m.reflections[0]);
  EXPECT_EQ(index.keyword_id("B"), 1u);
  EXPECT_EQ(index.keyword_id("NONE"), runtime::kNone);

  EXPECT_THROW(runtime::Index::decode(bytes, 3), runtime::IndexError) << "blob 3 is out of range";
  for (size_t n = 0; n < bytes.size(); ++n) EXPECT_THROW(runtime::Index::decode(bytes.substr(0, n), 4), runtime::IndexError) << n;
  const std::string record = runtime::encode_reflection(compute);
  for (size_t n = 0; n < record.size(); ++n) EXPECT_THROW(runtime::decode_reflection(record.substr(0, n)), runtime::IndexError) << n;
}

// Two passes of one name are refused, among 100,000: the check sorts the names (comparing every pair took 6.9 s for
// 50,000 passes, over a minute for the 150,000 a 3 MB index holds, in every game's open and kiln inspect).
TEST(Manifest, TheRuntimeIndexRefusesTwoPassesOfOneNameAmongAHundredThousand) {
  Manifest m;
  for (int p = 0; p < 100000; ++p) m.passes.emplace_back().name = "Pass" + std::to_string(p);
  EXPECT_EQ(runtime::Index::decode(runtime::encode(m), 0).passes.size(), 100000u);
  m.passes[99999].name = "Pass512";
  try {
    (void)runtime::Index::decode(runtime::encode(m), 0);
    FAIL() << "decoded";
  } catch (const runtime::IndexError& e) {
    EXPECT_NE(std::string(e.what()).find(": two passes are named 'Pass512'"), std::string::npos) << e.what();
  }
}

std::string error_reading(const json& j) {
  try {
    (void)j.get<Manifest>();
  } catch (const ManifestError& e) {
    return e.what();
  }
  return "(read)";
}

// Each mistake is named by its JSON pointer, and none escapes as a JSON library exception.
TEST(Manifest, RefusesWhatKilnDoesNotWriteAndSaysWhere) {
  const json good = sample_manifest();
  struct Case {
    std::string pointer;
    json value;  // null: remove the field
    std::string error;
  };
  const Case cases[] = {
      {"/name", nullptr, "top level: has no \"name\""},
      {"/binaries/1/stage", "amplification", "/binaries/1/stage: \"amplification\" is not a stage"},
      {"/binaries/0/blobs/dxil-9", 7, "/binaries/0/blobs/dxil-9: \"dxil-9\" is not a target"},
      {"/binaries/0/reflection", -1, "/binaries/0/reflection: is not an unsigned integer"},
      {"/binaries/0/reflection", uint64_t{4294967296}, "/binaries/0/reflection: 4294967296 is out of range"},
      {"/reflections/0/resources/1/kind", "texel_buffer", "/reflections/0/resources/1/kind: \"texel_buffer\" is not a resource kind"},
      {"/reflections/0/resources/0/members/1/offset", "64", "/reflections/0/resources/0/members/1/offset: is not an unsigned integer"},
      {"/reflections/0/resources/0/members", nullptr, "/reflections/0/resources/0: has no \"members\""},
      {"/reflections/0/glsl/blocks/0/kind", "texture", "/reflections/0/glsl/blocks/0/kind: is not a block kind"},
      {"/passes/0/variants/1/keywords/0", 5, "/passes/0/variants/1/keywords/0: is not a string"},
      {"/passes/0/keyword_groups/0/stages/0", "mesh", "/passes/0/keyword_groups/0/stages/0: \"mesh\" is not a stage"},
      {"/passes/0/layout", json::array(), "/passes/0/layout: is not an object"},
      {"/options/gl_clip_space_fixup", 1, "/options/gl_clip_space_fixup: is not a boolean"},
      {"/scene_features", json::array(), "/scene_features: is not an object"},
  };
  for (const Case& c : cases) {
    json bad = good;
    const json::json_pointer at(c.pointer);
    if (c.value.is_null()) bad[at.parent_pointer()].erase(at.back());
    else bad[at] = c.value;
    EXPECT_EQ(error_reading(bad), c.error) << c.pointer;
  }
  EXPECT_EQ(error_reading(json::array()), "top level: is not an object");
}

// Folded keywords' ids and offsets are derived from the groups by every reader (kiln/folded_keywords.hpp); the
// JSON's record of them is for people, and a manifest whose record disagrees is refused, as is one that drops it.
TEST(Manifest, TheFoldedKeywordsRecordMustBeTheOneTheGroupsGive) {
  Manifest m = sample_manifest();
  m.passes[0].keyword_groups.push_back({"specialization_constant_fragment", {"", "S", "T"}, stage_bit(Stage::Fragment)});
  m.passes[0].keyword_groups.push_back({"dynamic_branch", {"", "D"}, kAllStageBits});
  const json good = m;
  const json& folded = good["passes"][0]["folded_keywords"];
  ASSERT_EQ(folded.size(), 3u);
  EXPECT_EQ(folded[1]["keyword"], "T");
  EXPECT_EQ(folded[1]["constant_id"], kKeywordConstantIdBase + 1);
  EXPECT_EQ(folded[2]["block"], kKeywordBlockName);
  EXPECT_EQ(folded[2]["offset"], 0);
  EXPECT_EQ(good.get<Manifest>().passes, m.passes);
  EXPECT_EQ(runtime::Index::decode(runtime::encode(m), m.archive.blobs).folded.size(), 3u);
  for (const char* pointer : {"/passes/0/folded_keywords/1/constant_id", "/passes/0/folded_keywords/2/offset"}) {
    json bad = good;
    bad[json::json_pointer(pointer)] = 7;
    EXPECT_EQ(error_reading(bad), "/passes/0/folded_keywords: does not match the pass's keyword groups (kiln/folded_keywords.hpp)");
  }
  json dropped = good;
  dropped["passes"][0].erase("folded_keywords");
  EXPECT_NE(error_reading(dropped), "(read)");
  EXPECT_EQ(json(sample_manifest())["passes"][0].count("folded_keywords"), 0u);  // nothing folded: nothing written
}

TEST(Manifest, ChecksIndicesBetweenRecords) {
  Manifest m = sample_manifest();
  m.passes[0].variants[1].binaries[Stage::Fragment] = 2;
  try {
    m.check_indices();
    FAIL() << "accepted";
  } catch (const ManifestError& e) {
    EXPECT_EQ(std::string(e.what()), "/passes/0/variants/1/binaries/fragment: index 2 is out of range (2 binaries)");
  }
  m = sample_manifest();
  m.binaries[1].blobs[Target::Msl] = 4;
  EXPECT_THROW(m.check_indices(), ManifestError);
  m = sample_manifest();
  m.binaries[0].reflection = 1;
  EXPECT_THROW(m.check_indices(), ManifestError);
}

// Texel buffers and input attachments have kinds of their own; an input attachment's index is written (JSON) and
// encoded (runtime index) for it alone, so the records of every other kind keep the bytes they had.
TEST(Manifest, TexelBuffersAndInputAttachmentsRoundTripAndOtherRecordsKeepTheirBytes) {
  Resource attachment;
  attachment.name = "gbufferAlbedo";
  attachment.kind = ResourceKind::InputAttachment;
  attachment.binding = 2;
  attachment.input_attachment_index = 3;
  Resource texel;
  texel.name = "instanceData";
  texel.kind = ResourceKind::UniformTexelBuffer;
  texel.binding = 5;
  Reflection r;
  r.resources = {attachment, texel};
  EXPECT_EQ(json(r).at("resources").at(0).dump(),
            R"({"binding":2,"count":1,"input_attachment_index":3,"kind":"input_attachment","name":"gbufferAlbedo","set":0})");
  EXPECT_EQ(json(r).at("resources").at(1).dump(), R"({"binding":5,"count":1,"kind":"uniform_texel_buffer","name":"instanceData","set":0})");
  EXPECT_EQ(json(r).get<Reflection>(), r);
  EXPECT_EQ(runtime::decode_reflection(runtime::encode_reflection(r)), r);

  Reflection as_texture = r;
  as_texture.resources[0].kind = ResourceKind::Texture;
  as_texture.resources[0].input_attachment_index = 0;
  EXPECT_EQ(runtime::encode_reflection(r).size(), runtime::encode_reflection(as_texture).size() + 4);
  EXPECT_FALSE(json(as_texture).at("resources").at(0).contains("input_attachment_index"));
  // A kind past the last one is refused, not taken for another.
  std::string record = runtime::encode_reflection(as_texture);
  const size_t kind_at = 4 + 4 + attachment.name.size() + 1;  // resource count, then the name's length, bytes and NUL
  ASSERT_EQ(record[kind_at], static_cast<char>(ResourceKind::Texture));
  record[kind_at] = static_cast<char>(static_cast<int>(ResourceKind::InputAttachment) + 1);
  EXPECT_THROW(runtime::decode_reflection(record), runtime::IndexError);
}

TEST(Manifest, NamesEveryResourceKindBothWays) {
  for (ResourceKind kind : {ResourceKind::UniformBuffer, ResourceKind::StorageBuffer, ResourceKind::Texture, ResourceKind::Sampler,
                            ResourceKind::CombinedImageSampler, ResourceKind::StorageImage, ResourceKind::UniformTexelBuffer,
                            ResourceKind::StorageTexelBuffer, ResourceKind::InputAttachment})
    EXPECT_EQ(parse_resource_kind(resource_kind_name(kind)), kind);
  EXPECT_EQ(resource_kind_name(ResourceKind::UniformTexelBuffer), "uniform_texel_buffer");
  EXPECT_EQ(resource_kind_name(ResourceKind::StorageTexelBuffer), "storage_texel_buffer");
  EXPECT_EQ(resource_kind_name(ResourceKind::InputAttachment), "input_attachment");
  EXPECT_EQ(parse_resource_kind("buffer"), std::nullopt);
  for (const TargetName& t : kTargetNames) EXPECT_EQ(parse_target(t.name), t.target);
  for (Stage s : kAllStages) EXPECT_EQ(parse_stage(stage_name(s)), s);
}

}  // namespace
}  // namespace kiln
