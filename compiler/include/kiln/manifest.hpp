// SPDX-License-Identifier: Apache-2.0
// The variant pack's manifest (`<name>.manifest.json`, format kPackFormatVersion) and the reflection it
// records, as types. The compiler's reflection stage returns `Reflection`, the pack writer writes a
// `Manifest`, and the reader, `kiln inspect`, check-scene, diff-packs, lint and the verify renderer read one:
// no code walks the manifest by string keys, so a field change is a compile error.
//
// The JSON conversions (to_json/from_json) are declared in manifest_json.hpp, which is the compiler's and is not
// installed: the reader's public headers do not include nlohmann-json. Indices between records (a variant's
// binaries, a binary's blobs and reflection) are checked by check_indices, not by from_json.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "kiln/stage_target.hpp"

namespace kiln {

// `where` is a JSON pointer ("" for the top level); what() is "where: what".
class ManifestError : public std::runtime_error {
 public:
  ManifestError(std::string where, std::string what);
  const std::string& where() const { return where_; }
  const std::string& what_is_wrong() const { return what_; }
  // The same error one level down: "/binaries/3" + "/stage".
  ManifestError inside(std::string_view parent) const;

 private:
  std::string where_, what_;
};

// ---- Reflection: what a stage's SPIR-V binds and passes, and how each target binds it ----------------------

struct BlockMember {
  std::string name;
  uint32_t offset = 0;
  uint64_t size = 0;
  std::string type;                     // "float4", "float4x4", "float4[16]", "struct", ...
  std::optional<uint32_t> array_stride;  // arrays only
  friend bool operator==(const BlockMember&, const BlockMember&) = default;
};

// One per Vulkan descriptor type kiln reflects. New kinds go at the end: the values are the C API's and the runtime
// index's. Texture is a sampled image (never a Buffer<T>, which is UniformTexelBuffer; RWBuffer<T> is
// StorageTexelBuffer, not StorageImage); InputAttachment is HLSL's SubpassInput / SubpassInputMS.
enum class ResourceKind : uint8_t {
  UniformBuffer, StorageBuffer, Texture, Sampler, CombinedImageSampler, StorageImage,
  UniformTexelBuffer, StorageTexelBuffer, InputAttachment
};
std::string_view resource_kind_name(ResourceKind kind);  // "uniform_buffer", ...
std::optional<ResourceKind> parse_resource_kind(std::string_view name);
constexpr bool is_block(ResourceKind kind) { return kind == ResourceKind::UniformBuffer || kind == ResourceKind::StorageBuffer; }
constexpr bool is_image(ResourceKind kind) {
  return kind == ResourceKind::Texture || kind == ResourceKind::CombinedImageSampler || kind == ResourceKind::StorageImage;
}

struct Resource {
  std::string name;
  ResourceKind kind = ResourceKind::UniformBuffer;
  uint32_t set = 0;
  uint32_t binding = 0;
  uint32_t count = 1;  // array size
  // Blocks (is_block(kind)): the declared size and the members.
  uint64_t size = 0;
  std::vector<BlockMember> members;
  // Images (is_image(kind)): "1D", "2D", "2DArray", "3D", "Cube", "CubeArray"; depth comparison.
  std::string dimension;
  bool depth = false;
  // Input attachments: the attachment's index in the subpass's input attachments ([[vk::input_attachment_index(N)]]).
  uint32_t input_attachment_index = 0;
  friend bool operator==(const Resource&, const Resource&) = default;
};

struct PushConstantBlock {
  std::string name;
  uint64_t size = 0;
  std::vector<BlockMember> members;
  friend bool operator==(const PushConstantBlock&, const PushConstantBlock&) = default;
};

struct StageVariable {
  std::string name;
  uint32_t location = 0;
  std::string type;      // "float4", ...
  std::string semantic;  // the HLSL semantic, upper case ("POSITION", "TEXCOORD0", "SV_TARGET"); empty when none
  friend bool operator==(const StageVariable&, const StageVariable&) = default;
};

// GLSL and GLSL ES: HLSL's separate textures and samplers become combined samplers, each at its texture's
// binding; blocks by the interface name glGetUniformBlockIndex takes.
struct GlCombinedSampler {
  std::string name;  // "<texture>_<sampler>"; the sampler is "kiln_no_sampler" for Load/GetDimensions
  std::string texture;
  std::string sampler;
  uint32_t binding = 0;
  friend bool operator==(const GlCombinedSampler&, const GlCombinedSampler&) = default;
};
struct GlBlock {
  std::string name;
  ResourceKind kind = ResourceKind::UniformBuffer;  // uniform_buffer or storage_buffer
  uint32_t binding = 0;
  friend bool operator==(const GlBlock&, const GlBlock&) = default;
};
struct GlBindings {
  std::vector<GlCombinedSampler> combined_image_samplers;  // by name
  std::vector<GlBlock> blocks;
  friend bool operator==(const GlBindings&, const GlBindings&) = default;
};

// MSL: the [[buffer(n)]], [[texture(n)]] and [[sampler(n)]] index of each resource the entry point uses.
enum class MslResourceKind : uint8_t { Buffer, Texture, Sampler };
struct MslResource {
  std::string name;  // as the HLSL declares it
  MslResourceKind kind = MslResourceKind::Buffer;
  uint32_t index = 0;
  friend bool operator==(const MslResource&, const MslResource&) = default;
};
struct MslBindings {
  std::vector<MslResource> resources;  // by name
  friend bool operator==(const MslBindings&, const MslBindings&) = default;
};

struct Reflection {
  std::vector<Resource> resources;  // by (set, binding, name)
  std::vector<PushConstantBlock> push_constants;
  std::vector<StageVariable> inputs;   // by location
  std::vector<StageVariable> outputs;  // by location
  // A compute shader's thread-group size (HLSL [numthreads(x, y, z)]); absent for other stages.
  std::optional<std::array<uint32_t, 3>> local_size;
  // Each target's own binding records, present when the binary was built for it.
  std::optional<GlBindings> glsl;
  std::optional<GlBindings> gles;
  std::optional<MslBindings> msl;

  const GlBindings* gl(bool es) const { return es ? (gles ? &*gles : nullptr) : (glsl ? &*glsl : nullptr); }
  bool holds(const Resource& resource) const;  // same name, kind, slot and shape
  friend bool operator==(const Reflection&, const Reflection&) = default;
};

// What every binary of a pass binds, merged: what a renderer makes its descriptor set layouts from.
struct PassLayout {
  std::vector<Resource> resources;  // by (set, binding)
  std::vector<PushConstantBlock> push_constants;
  friend bool operator==(const PassLayout&, const PassLayout&) = default;
};

// ---- The manifest ---------------------------------------------------------------------------------------------

struct ManifestKeywordGroup {
  std::string pragma;               // "multi_compile_fragment", ...
  std::vector<std::string> values;  // "" is the off value ("_" in the file)
  StageMask stages = kAllStageBits;
  friend bool operator==(const ManifestKeywordGroup&, const ManifestKeywordGroup&) = default;
};

struct ManifestVariant {
  std::vector<std::string> keywords;     // sorted
  std::map<Stage, uint32_t> binaries;  // index into Manifest::binaries
  friend bool operator==(const ManifestVariant&, const ManifestVariant&) = default;
};

struct ManifestPass {
  std::string name;
  std::map<Stage, std::string> entry_points;  // "stages" in the file
  std::vector<ManifestKeywordGroup> keyword_groups;
  PassLayout layout;
  std::vector<ManifestVariant> variants;
  std::string bindings;                       // BindingOptions::canonical(); empty: the defaults
  std::map<std::string, std::string> defines;  // name -> value
  std::vector<Target> targets;                 // the pass's own targets; empty: the pack's (options.targets)
  friend bool operator==(const ManifestPass&, const ManifestPass&) = default;
};

struct ManifestBinary {
  Stage stage = Stage::Vertex;
  std::string entry;
  std::map<Target, uint32_t> blobs;  // target -> blob id in the archive
  uint32_t reflection = 0;            // index into Manifest::reflections
  friend bool operator==(const ManifestBinary&, const ManifestBinary&) = default;
};

struct ManifestConstraint {
  std::string keyword;
  std::vector<std::string> requires_all;  // "requires" in the file
  std::vector<std::string> requires_any;
  std::vector<std::string> excludes;
  std::string reason;
  friend bool operator==(const ManifestConstraint&, const ManifestConstraint&) = default;
};

struct ManifestMaterial {
  std::string name;
  std::set<std::string> keywords;
  friend bool operator==(const ManifestMaterial&, const ManifestMaterial&) = default;
};

struct ManifestTools {
  std::string frontend;     // "glslang 12.x.y"
  std::string spirv_tools;  // the library's own version string
  std::string spirv_cross;  // "C API 0.54.0, libraries sha256 ..."
  friend bool operator==(const ManifestTools&, const ManifestTools&) = default;
};

struct ManifestOptions {
  bool optimize = true;
  std::string optimizer_recipe;  // "kiln" or "O" (docs/design.md, "The optimizer recipe")
  std::vector<Target> targets;
  std::string spirv_env;  // "vulkan1.1"
  uint32_t glsl_version = 0;
  uint32_t gles_version = 0;
  std::string msl_version;
  bool gl_clip_space_fixup = true;
  friend bool operator==(const ManifestOptions&, const ManifestOptions&) = default;
};

// What the build's stages made of the pack: variants declared, valid and kept; stage instances (variants x stages);
// distinct (pass, stage, stage keywords) preprocessed; distinct preprocessed text + entry + stage compiled (front ends
// run); distinct front-end modules (back ends run); distinct optimized SPIR-V (what the pack stores).
struct ManifestFunnel {
  uint64_t declared = 0, valid = 0, kept = 0, stage_instances = 0, unique_preprocessed = 0, unique_compiles = 0,
           unique_modules = 0, unique_binaries = 0;
  friend bool operator==(const ManifestFunnel&, const ManifestFunnel&) = default;
};

struct ManifestArchive {
  std::string file;  // `<name>.<xxh3_64>.kpack`, beside the manifest
  uint64_t size = 0;
  std::string xxh3_64;
  uint64_t blobs = 0;
  friend bool operator==(const ManifestArchive&, const ManifestArchive&) = default;
};

struct Manifest {
  uint32_t format_version = 0;
  std::string name;
  std::string kiln_version;
  ManifestTools tools;
  ManifestOptions options;
  std::string inputs_hash;
  ManifestFunnel funnel;
  std::vector<ManifestConstraint> constraints;
  std::vector<ManifestMaterial> materials;
  // The pack definition's scene_features table (feature -> value -> keywords) as compact JSON text, recorded as
  // written for check-scene; its meaning is the pack definition's (docs/scenes.md). Text, not a JSON value, so
  // that this header (installed with the reader) does not need nlohmann-json.
  std::string scene_features_json = "{}";
  std::vector<ManifestPass> passes;
  std::vector<ManifestBinary> binaries;
  std::vector<Reflection> reflections;
  ManifestArchive archive;

  const ManifestPass* pass(std::string_view name) const;  // null when the pack has no such pass
  // Throws ManifestError for an index out of range (a variant's binary, a binary's blob or reflection).
  void check_indices() const;
};

}  // namespace kiln
