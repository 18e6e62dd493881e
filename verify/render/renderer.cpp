// SPDX-License-Identifier: Apache-2.0
#include "render/renderer.hpp"

#include "render/scene_data.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <list>
#include <set>
#include <sstream>
#include <stdexcept>

namespace kiln::render {
namespace {

using nlohmann::json;

constexpr VkFormat kColorFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
constexpr uint32_t kGBufferTargets = 5;

[[noreturn]] void fail(const std::string& message) { render_error(message); }

bool has(const std::vector<std::string>& keywords, const char* keyword) {
  return std::find(keywords.begin(), keywords.end(), keyword) != keywords.end();
}

struct Texture {
  VkImage image = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
  ImageDesc desc;
};

struct GpuMesh {
  HostBuffer vertices;
  HostBuffer indices;
  uint32_t index_count = 0;
};

// A render pass + framebuffer over color targets and a depth target.
struct Target {
  VkRenderPass pass = VK_NULL_HANDLE;
  VkFramebuffer framebuffer = VK_NULL_HANDLE;
  std::vector<Texture> colors;
  Texture depth;
  uint32_t width = 0, height = 0;
};

// One descriptor-set layout built from a pass's reflected layout (every resource, both stages).
// A --coverage pack's passes also bind the coverage buffer (kiln/coverage_map.hpp): one per pass, zeroed, read
// after each draw.
struct PassLayout {
  const std::vector<Resource>* resources = nullptr;
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  VkPipelineLayout pipeline_layout = VK_NULL_HANDLE;
  HostBuffer coverage;
  // A folded pack's dynamic branches (kiln/folded_keywords.hpp): the block the variant's bools are written into
  // before each draw.
  HostBuffer keywords;
};

// A variant's specialization constants for one stage (kiln/folded_keywords.hpp): 4 bytes each, a VkBool32 or an int.
struct StageSpecialization {
  std::vector<VkSpecializationMapEntry> entries;
  std::vector<uint32_t> data;
  VkSpecializationInfo info{};
  StageSpecialization(const SelectedVariant& variant, Stage stage) {
    for (const KeywordValue& v : variant.values)
      if (is_constant(v.kind) && v.sets() && (v.stages & stage_bit(stage))) {
        entries.push_back({v.slot, static_cast<uint32_t>(data.size() * sizeof(uint32_t)), sizeof(uint32_t)});
        data.push_back(v.data());
      }
    info = {static_cast<uint32_t>(entries.size()), entries.data(), data.size() * sizeof(uint32_t), data.data()};
  }
  const VkSpecializationInfo* get() const { return entries.empty() ? nullptr : &info; }
};

// A variant's specialization constants as a pipeline cache key: slot and value of each.
std::vector<uint32_t> constants_of(const SelectedVariant& variant) {
  std::vector<uint32_t> out;
  for (const KeywordValue& v : variant.values)
    if (is_constant(v.kind) && v.sets()) out.insert(out.end(), {v.slot, v.data()});
  return out;
}

// Writes a variant's dynamic-branch bools into its pass's keyword block (nothing when the pass has none).
void write_keyword_block(const PassLayout& layout, const SelectedVariant& variant) {
  if (!layout.keywords.buffer) return;
  for (const KeywordValue& v : variant.values)
    if (v.kind == KeywordKind::DynamicBranch && v.slot + 4 <= layout.keywords.size) {
      const uint32_t word = v.data();
      std::memcpy(static_cast<uint8_t*>(layout.keywords.mapped) + v.slot, &word, 4);
    }
}

VkDescriptorType descriptor_type(ResourceKind kind) {
  switch (kind) {
    case ResourceKind::UniformBuffer: return VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    case ResourceKind::StorageBuffer: return VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    case ResourceKind::Texture: return VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE;
    case ResourceKind::Sampler: return VK_DESCRIPTOR_TYPE_SAMPLER;
    default: fail("reflected resource kind '" + std::string(resource_kind_name(kind)) + "' is not supported by the renderer");
  }
}

}  // namespace


struct SceneRenderer::State {
  VulkanContext& context;
  const PackReader& pack;
  VulkanObjects objects;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  SceneData data;
  GpuMesh sphere, plane;
  Texture dfg, environment_map;
  VkSampler compare_sampler = VK_NULL_HANDLE, linear_sampler = VK_NULL_HANDLE;
  PassLayout forward, shadow;
  std::vector<HostBuffer> per_material, per_object;
  HostBuffer lights, tiles, shadow_matrices;
  struct Frame {
    FrameSetup setup;
    HostBuffer per_frame;
    Texture main_atlas;
    std::vector<VkDescriptorSet> object_sets;  // Forward pass, per object
  };
  std::map<int, Frame> frames;  // by cascade count
  Texture additional_atlas;
  bool additional_rendered = false;
  Target color_target;
  HostBuffer readback;
  // Passes other than Forward and ShadowCaster (DepthOnly, DepthNormals): their layout and per-object sets.
  struct SimplePass {
    PassLayout layout;
    std::vector<VkDescriptorSet> object_sets;
  };
  std::map<std::string, SimplePass> simple_passes;
  // Image pipelines by what makes them distinct: variants whose SPIR-V modules are byte-identical (a keyword
  // no stage reads, a vertex stage many fragment variants share) draw with one pipeline, compiled once.
  // The most recently used few are kept (kiln test renders the variants of one pipeline one after another).
  struct CachedPipeline {
    std::string pass;
    std::string_view vertex, fragment;  // SPIR-V bytes (owned by the pack reader)
    std::string vertex_entry, fragment_entry;
    std::vector<uint32_t> constants;  // the variant's specialization constants: slot, value, ...
    std::unique_ptr<VulkanObjects> objects;
    VkPipeline pipeline = VK_NULL_HANDLE;
  };
  static constexpr size_t kCachedPipelines = 8;
  std::list<CachedPipeline> pipelines;  // most recent first; destroyed before `objects` (declared after it)
  CoverageRecorder* coverage = nullptr;

  State(VulkanContext& c, const PackReader& p, const Scene& scene) : context(c), pack(p), objects(c), data(p, scene) {}

  // The buffers the Forward and GBuffer passes bind, for one object of a frame.
  VkDescriptorBufferInfo buffer_info(const std::string& name, size_t object, const Frame& frame) const {
    if (name == "PerFrame") return {frame.per_frame.buffer, 0, VK_WHOLE_SIZE};
    if (name == "PerMaterial") return {per_material.at(object).buffer, 0, VK_WHOLE_SIZE};
    if (name == "PerObject") return {per_object.at(object).buffer, 0, VK_WHOLE_SIZE};
    if (name == "_AdditionalLights") return {lights.buffer, 0, VK_WHOLE_SIZE};
    if (name == "_TileLightIndices") return {tiles.buffer, 0, VK_WHOLE_SIZE};
    if (name == "_AdditionalShadowMatrices") return {shadow_matrices.buffer, 0, VK_WHOLE_SIZE};
    fail("no buffer for '" + name + "'");
  }
};

namespace {

HostBuffer upload_buffer(VulkanObjects& objects, const Bytes& bytes, VkBufferUsageFlags usage) {
  HostBuffer b = objects.host_buffer(std::max<size_t>(bytes.size(), 16), usage);
  std::memcpy(b.mapped, bytes.data(), bytes.size());
  return b;
}

GpuMesh upload_mesh(VulkanObjects& objects, const Mesh& mesh) {
  GpuMesh g;
  g.vertices = objects.host_buffer(mesh.vertices.size() * 4, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT);
  std::memcpy(g.vertices.mapped, mesh.vertices.data(), mesh.vertices.size() * 4);
  g.indices = objects.host_buffer(mesh.indices.size() * 4, VK_BUFFER_USAGE_INDEX_BUFFER_BIT);
  std::memcpy(g.indices.mapped, mesh.indices.data(), mesh.indices.size() * 4);
  g.index_count = static_cast<uint32_t>(mesh.indices.size());
  return g;
}

// Uploads texels (per layer, per mip, tightly packed float data in `levels[mip][layer]`).
Texture upload_texture(VulkanContext& context, VulkanObjects& objects, ImageDesc desc,
                       const std::vector<std::vector<const float*>>& levels, uint32_t texel_floats) {
  desc.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  Texture t{objects.image(desc), VK_NULL_HANDLE, desc};
  t.view = objects.view(t.image, desc);
  size_t total = 0;
  for (uint32_t m = 0; m < desc.mip_levels; ++m)
    total += size_t(desc.layers) * std::max(1u, desc.width >> m) * std::max(1u, desc.height >> m) * texel_floats * 4;
  HostBuffer staging = objects.host_buffer(total, VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
  std::vector<VkBufferImageCopy> regions;
  size_t offset = 0;
  for (uint32_t m = 0; m < desc.mip_levels; ++m) {
    uint32_t w = std::max(1u, desc.width >> m), h = std::max(1u, desc.height >> m);
    for (uint32_t layer = 0; layer < desc.layers; ++layer) {
      size_t bytes = size_t(w) * h * texel_floats * 4;
      std::memcpy(static_cast<uint8_t*>(staging.mapped) + offset, levels[m][layer], bytes);
      VkBufferImageCopy region{};
      region.bufferOffset = offset;
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, m, layer, 1};
      region.imageExtent = {w, h, 1};
      regions.push_back(region);
      offset += bytes;
    }
  }
  context.submit([&](VkCommandBuffer cmd) {
    image_barrier(cmd, t.image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                  VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, VK_ACCESS_TRANSFER_WRITE_BIT,
                  VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
    vkCmdCopyBufferToImage(cmd, staging.buffer, t.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                           static_cast<uint32_t>(regions.size()), regions.data());
    image_barrier(cmd, t.image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                  VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT,
                  VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT);
  });
  return t;
}

// An attachment cleared at the start of its render pass and stored at the end.
VkAttachmentDescription cleared_attachment(VkFormat format, VkImageLayout final_layout) {
  VkAttachmentDescription a{};
  a.format = format;
  a.samples = VK_SAMPLE_COUNT_1_BIT;
  a.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  a.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  a.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  a.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  a.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  a.finalLayout = final_layout;
  return a;
}

Target make_target(VulkanContext& context, VulkanObjects& objects, uint32_t width, uint32_t height, uint32_t colors,
                   VkImageLayout depth_final) {
  Target t;
  t.width = width;
  t.height = height;
  std::vector<VkAttachmentDescription> attachments;
  std::vector<VkAttachmentReference> color_refs;
  std::vector<VkImageView> views;
  for (uint32_t i = 0; i < colors; ++i) {
    ImageDesc d{kColorFormat, width, height};
    d.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    Texture tex{objects.image(d), VK_NULL_HANDLE, d};
    tex.view = objects.view(tex.image, d);
    t.colors.push_back(tex);
    views.push_back(tex.view);
    attachments.push_back(cleared_attachment(kColorFormat, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL));
    color_refs.push_back({i, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL});
  }
  ImageDesc dd{kDepthFormat, width, height};
  dd.usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  t.depth = {objects.image(dd), VK_NULL_HANDLE, dd};
  t.depth.view = objects.view(t.depth.image, dd);
  views.push_back(t.depth.view);
  attachments.push_back(cleared_attachment(kDepthFormat, depth_final));
  VkAttachmentReference depth_ref{colors, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
  VkSubpassDescription subpass{};
  subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  subpass.colorAttachmentCount = colors;
  subpass.pColorAttachments = color_refs.data();
  subpass.pDepthStencilAttachment = &depth_ref;
  // Later passes sample the depth (shadow maps) or copy the colors: make the writes visible to them.
  VkSubpassDependency dependency{};
  dependency.srcSubpass = 0;
  dependency.dstSubpass = VK_SUBPASS_EXTERNAL;
  dependency.srcStageMask = VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  dependency.dstStageMask = VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT;
  dependency.srcAccessMask = VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  dependency.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT;
  VkRenderPassCreateInfo info{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
  info.attachmentCount = static_cast<uint32_t>(attachments.size());
  info.pAttachments = attachments.data();
  info.subpassCount = 1;
  info.pSubpasses = &subpass;
  info.dependencyCount = 1;
  info.pDependencies = &dependency;
  check(vkCreateRenderPass(context.device(), &info, nullptr, &t.pass), "vkCreateRenderPass");
  objects.adopt(t.pass);
  VkFramebufferCreateInfo fb{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
  fb.renderPass = t.pass;
  fb.attachmentCount = static_cast<uint32_t>(views.size());
  fb.pAttachments = views.data();
  fb.width = width;
  fb.height = height;
  fb.layers = 1;
  check(vkCreateFramebuffer(context.device(), &fb, nullptr, &t.framebuffer), "vkCreateFramebuffer");
  objects.adopt(t.framebuffer);
  return t;
}

PassLayout make_pass_layout(VulkanContext& context, VulkanObjects& objects, const ManifestPass& pass) {
  PassLayout layout;
  layout.resources = &pass.layout.resources;
  std::vector<VkDescriptorSetLayoutBinding> bindings;
  for (const Resource& r : *layout.resources) {
    if (r.set != 0) fail("resource " + r.name + " is in set " + std::to_string(r.set) + "; the renderer binds set 0 only");
    bindings.push_back({r.binding, descriptor_type(r.kind), r.count, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, nullptr});
    if (r.name == kCoverageBufferName && r.kind == ResourceKind::StorageBuffer) {
      layout.coverage = objects.host_buffer(VkDeviceSize{kCoverageBufferWords} * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
      std::memset(layout.coverage.mapped, 0, layout.coverage.size);
    }
    if (r.name == kKeywordBlockName && r.kind == ResourceKind::UniformBuffer) {
      layout.keywords = objects.host_buffer(std::max<VkDeviceSize>(r.size, 16), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
      std::memset(layout.keywords.mapped, 0, layout.keywords.size);
    }
  }
  VkDescriptorSetLayoutCreateInfo set_info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  set_info.bindingCount = static_cast<uint32_t>(bindings.size());
  set_info.pBindings = bindings.data();
  check(vkCreateDescriptorSetLayout(context.device(), &set_info, nullptr, &layout.set_layout),
        "vkCreateDescriptorSetLayout");
  objects.adopt(layout.set_layout);
  VkPipelineLayoutCreateInfo info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  info.setLayoutCount = 1;
  info.pSetLayouts = &layout.set_layout;
  check(vkCreatePipelineLayout(context.device(), &info, nullptr, &layout.pipeline_layout), "vkCreatePipelineLayout");
  objects.adopt(layout.pipeline_layout);
  return layout;
}

std::vector<VkVertexInputAttributeDescription> vertex_attributes(const StageView& vertex) {
  static constexpr VkFormat formats[] = {VK_FORMAT_UNDEFINED, VK_FORMAT_R32_SFLOAT, VK_FORMAT_R32G32_SFLOAT,
                                         VK_FORMAT_R32G32B32_SFLOAT, VK_FORMAT_R32G32B32A32_SFLOAT};
  std::vector<VkVertexInputAttributeDescription> attributes;
  for (const MeshAttribute& a : mesh_attributes(vertex)) attributes.push_back({a.location, 0, formats[a.components], a.offset});
  return attributes;
}

VkPipeline make_pipeline(VulkanContext& context, VulkanObjects& objects, const SelectedVariant& variant,
                         VkRenderPass pass, uint32_t color_targets, VkPipelineLayout layout) {
  const StageView* vs = variant.stage("vertex");
  const StageView* fs = variant.stage("fragment");
  if (!vs || !fs || vs->spirv.empty() || fs->spirv.empty())
    fail("variant " + variant.pass + " #" + std::to_string(variant.index) + " has no SPIR-V (build the pack with the spirv target)");
  GraphicsPipelineDesc desc;
  const StageSpecialization vertex_constants(variant, Stage::Vertex), fragment_constants(variant, Stage::Fragment);
  desc.vertex_specialization = vertex_constants.get();
  desc.fragment_specialization = fragment_constants.get();
  desc.vertex = objects.shader_module(vs->spirv.data(), vs->spirv.size());
  desc.vertex_entry = vs->entry_point.c_str();
  desc.fragment = objects.shader_module(fs->spirv.data(), fs->spirv.size());
  desc.fragment_entry = fs->entry_point.c_str();
  desc.vertex_bindings = {{0, kVertexFloats * 4, VK_VERTEX_INPUT_RATE_VERTEX}};
  desc.vertex_attributes = vertex_attributes(*vs);
  desc.color_targets = color_targets;
  desc.depth = true;  // every pass here renders into a depth attachment
  desc.layout = layout;
  desc.render_pass = pass;
  return create_graphics_pipeline(context.device(), desc);
}

void set_viewport(VkCommandBuffer cmd, uint32_t x, uint32_t y, uint32_t w, uint32_t h) {
  VkViewport viewport{float(x), float(y), float(w), float(h), 0, 1};
  VkRect2D scissor{{int32_t(x), int32_t(y)}, {w, h}};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
}

Image read_color(VulkanContext& context, const HostBuffer& readback, VkImage image, uint32_t width, uint32_t height) {
  context.submit([&](VkCommandBuffer cmd) {
    VkBufferImageCopy copy{};
    copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    copy.imageExtent = {width, height, 1};
    vkCmdCopyImageToBuffer(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback.buffer, 1, &copy);
  });
  Image out{width, height, {}};
  out.rgba.resize(size_t(width) * height * 4);
  std::memcpy(out.rgba.data(), readback.mapped, out.rgba.size() * 4);
  return out;
}

}  // namespace

SceneRenderer::SceneRenderer(VulkanContext& context, const PackReader& pack, const Scene& scene, uint32_t width,
                             uint32_t height)
    : scene_(scene), width_(width ? width : scene.width), height_(height ? height : scene.height) {
  scene_.width = width_;
  scene_.height = height_;
  state_ = std::make_unique<State>(context, pack, scene_);
  State& s = *state_;
  VkDevice device = context.device();
  s.sphere = upload_mesh(s.objects, make_sphere(64, 32));
  s.plane = upload_mesh(s.objects, make_plane(32));

  // Environment cube (prefiltered mips) and the DFG table.
  const Environment& environment = s.data.environment();
  ImageDesc cube{VK_FORMAT_R32G32B32A32_SFLOAT, environment.size, environment.size, environment.mips, 6, true};
  std::vector<std::vector<const float*>> cube_levels;
  for (uint32_t m = 0; m < environment.mips; ++m) {
    uint32_t n = environment.level_size(m);
    cube_levels.emplace_back();
    for (uint32_t face = 0; face < 6; ++face) cube_levels.back().push_back(environment.levels[m].data() + size_t(face) * n * n * 4);
  }
  s.environment_map = upload_texture(context, s.objects, cube, cube_levels, 4);
  const DfgTable& dfg = s.data.dfg();
  s.dfg = upload_texture(context, s.objects, {VK_FORMAT_R32G32_SFLOAT, dfg.width, dfg.height}, {{dfg.rg.data()}}, 2);

  VkSamplerCreateInfo linear{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  linear.magFilter = linear.minFilter = VK_FILTER_LINEAR;
  linear.mipmapMode = VK_SAMPLER_MIPMAP_MODE_LINEAR;
  linear.addressModeU = linear.addressModeV = linear.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  linear.maxLod = 16.0f;
  s.linear_sampler = s.objects.sampler(linear);
  // Nearest compared taps: each tap is one texel's test, which the CPU reference reproduces exactly.
  VkSamplerCreateInfo compare{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  compare.magFilter = compare.minFilter = VK_FILTER_NEAREST;
  compare.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  compare.addressModeU = compare.addressModeV = compare.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  compare.compareEnable = VK_TRUE;
  compare.compareOp = VK_COMPARE_OP_LESS_OR_EQUAL;
  s.compare_sampler = s.objects.sampler(compare);

  s.forward = make_pass_layout(context, s.objects, s.data.forward_pass());
  s.shadow = make_pass_layout(context, s.objects, s.data.shadow_pass());
  const SceneData::Frame& base_frame = s.data.frame(1);
  for (size_t i = 0; i < scene_.objects.size(); ++i) {
    s.per_material.push_back(upload_buffer(s.objects, s.data.buffer("PerMaterial", i, base_frame), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT));
    s.per_object.push_back(upload_buffer(s.objects, s.data.buffer("PerObject", i, base_frame), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT));
  }
  s.lights = upload_buffer(s.objects, s.data.buffer("_AdditionalLights", 0, base_frame), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  s.tiles = upload_buffer(s.objects, s.data.buffer("_TileLightIndices", 0, base_frame), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  s.shadow_matrices = upload_buffer(s.objects, s.data.buffer("_AdditionalShadowMatrices", 0, base_frame),
                                    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  const FrameSetup& base = base_frame.setup;

  ImageDesc atlas{kDepthFormat, std::max(1u, base.additional_atlas_width), std::max(1u, base.additional_atlas_height)};
  atlas.usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  s.additional_atlas = {s.objects.image(atlas), VK_NULL_HANDLE, atlas};
  s.additional_atlas.view = s.objects.view(s.additional_atlas.image, atlas);

  // Descriptor pool: Forward sets for two frame layouts, shadow sets for every view, G-buffer sets.
  const uint32_t sets = static_cast<uint32_t>(scene_.objects.size()) * (2 + 16 + 2 + 2) + 8;
  VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, sets * 4}, {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, sets * 4},
                                  {VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, sets * 4}, {VK_DESCRIPTOR_TYPE_SAMPLER, sets * 2}};
  VkDescriptorPoolCreateInfo pool_info{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  pool_info.maxSets = sets;
  pool_info.poolSizeCount = 4;
  pool_info.pPoolSizes = sizes;
  check(vkCreateDescriptorPool(device, &pool_info, nullptr, &s.pool), "vkCreateDescriptorPool");
  s.objects.adopt(s.pool);

  s.color_target = make_target(context, s.objects, width_, height_, 1, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL);
  s.readback = s.objects.host_buffer(size_t(width_) * height_ * 16, VK_BUFFER_USAGE_TRANSFER_DST_BIT);
}

SceneRenderer::~SceneRenderer() = default;

void SceneRenderer::record_coverage(CoverageRecorder* recorder) { state_->coverage = recorder; }

namespace {

// Writes every resource of `layout` into `set`: the frame's buffers and textures, the object's constants,
// and (shadow passes) the shadow view's constants.
void write_set(VkDevice device, VkDescriptorSet set, const PassLayout& layout,
               const std::function<VkDescriptorBufferInfo(const std::string&)>& buffer,
               const std::function<VkDescriptorImageInfo(const std::string&)>& image) {
  std::vector<VkWriteDescriptorSet> writes;
  std::vector<std::unique_ptr<VkDescriptorBufferInfo>> buffers;
  std::vector<std::unique_ptr<VkDescriptorImageInfo>> images;
  for (const Resource& r : *layout.resources) {
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = set;
    w.dstBinding = r.binding;
    w.descriptorCount = 1;
    w.descriptorType = descriptor_type(r.kind);
    const std::string& name = r.name;
    if (layout.coverage.buffer && name == kCoverageBufferName) {
      buffers.push_back(std::make_unique<VkDescriptorBufferInfo>(VkDescriptorBufferInfo{layout.coverage.buffer, 0, VK_WHOLE_SIZE}));
      w.pBufferInfo = buffers.back().get();
    } else if (layout.keywords.buffer && name == kKeywordBlockName) {
      buffers.push_back(std::make_unique<VkDescriptorBufferInfo>(VkDescriptorBufferInfo{layout.keywords.buffer, 0, VK_WHOLE_SIZE}));
      w.pBufferInfo = buffers.back().get();
    } else if (w.descriptorType == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER || w.descriptorType == VK_DESCRIPTOR_TYPE_STORAGE_BUFFER) {
      buffers.push_back(std::make_unique<VkDescriptorBufferInfo>(buffer(name)));
      w.pBufferInfo = buffers.back().get();
    } else {
      images.push_back(std::make_unique<VkDescriptorImageInfo>(image(name)));
      w.pImageInfo = images.back().get();
    }
    writes.push_back(w);
  }
  vkUpdateDescriptorSets(device, static_cast<uint32_t>(writes.size()), writes.data(), 0, nullptr);
}

// After a draw with `variant`'s pipeline: the words its stages set in the pass's coverage buffer, to the recorder
// (which clears them for the next draw). Nothing when no recorder listens or the pack is not instrumented.
void credit_coverage(VulkanContext& context, CoverageRecorder* recorder, const PassLayout& layout,
                     const SelectedVariant& variant, std::string_view role = {}) {
  if (!recorder || !layout.coverage.buffer) return;
  context.submit([](VkCommandBuffer cmd) {  // the shaders' writes, made visible to the host
    VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT,
                         VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &barrier, 0, nullptr, 0, nullptr);
  });
  std::vector<std::string_view> modules;
  for (const StageView& stage : variant.stages) modules.push_back(stage.spirv);
  recorder->credit(modules, static_cast<uint32_t*>(layout.coverage.mapped), layout.coverage.size / 4, role);
}

VkDescriptorSet allocate_set(VkDevice device, VkDescriptorPool pool, VkDescriptorSetLayout layout) {
  VkDescriptorSetAllocateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  info.descriptorPool = pool;
  info.descriptorSetCount = 1;
  info.pSetLayouts = &layout;
  VkDescriptorSet set;
  check(vkAllocateDescriptorSets(device, &info, &set), "vkAllocateDescriptorSets");
  return set;
}

void draw_objects(VkCommandBuffer cmd, const Scene& scene, const GpuMesh& sphere, const GpuMesh& plane,
                  VkPipelineLayout layout, const std::vector<VkDescriptorSet>& sets) {
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    const GpuMesh& mesh = scene.objects[i].shape == Object::Shape::Plane ? plane : sphere;
    VkDeviceSize offset = 0;
    vkCmdBindVertexBuffers(cmd, 0, 1, &mesh.vertices.buffer, &offset);
    vkCmdBindIndexBuffer(cmd, mesh.indices.buffer, 0, VK_INDEX_TYPE_UINT32);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, 0, 1, &sets[i], 0, nullptr);
    vkCmdDrawIndexed(cmd, mesh.index_count, 1, 0, 0, 0);
  }
}

}  // namespace

const FrameSetup& SceneRenderer::frame(int cascades) {
  State& s = *state_;
  auto found = s.frames.find(cascades);
  if (found != s.frames.end()) return found->second.setup;
  State::Frame& f = s.frames[cascades];
  const SceneData::Frame& data = s.data.frame(cascades);
  f.setup = data.setup;
  f.per_frame = upload_buffer(s.objects, data.per_frame, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
  const Scene& sc = scene_;

  ImageDesc atlas{kDepthFormat, f.setup.main_atlas_size, f.setup.main_atlas_size};
  atlas.usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  f.main_atlas = {s.objects.image(atlas), VK_NULL_HANDLE, atlas};
  f.main_atlas.view = s.objects.view(f.main_atlas.image, atlas);

  VkDevice device = s.context.device();
  for (size_t i = 0; i < sc.objects.size(); ++i) {
    VkDescriptorSet set = allocate_set(device, s.pool, s.forward.set_layout);
    write_set(
        device, set, s.forward,
        [&](const std::string& name) { return s.buffer_info(name, i, f); },
        [&](const std::string& name) -> VkDescriptorImageInfo {
          if (name == "_MainLightShadowMap") return {VK_NULL_HANDLE, f.main_atlas.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
          if (name == "_AdditionalLightsShadowMap")
            return {VK_NULL_HANDLE, s.additional_atlas.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
          if (name == "_EnvironmentMap") return {VK_NULL_HANDLE, s.environment_map.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
          if (name == "_DFG") return {VK_NULL_HANDLE, s.dfg.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
          if (name == "sampler_ShadowCompare") return {s.compare_sampler, VK_NULL_HANDLE, VK_IMAGE_LAYOUT_UNDEFINED};
          if (name == "sampler_LinearClamp") return {s.linear_sampler, VK_NULL_HANDLE, VK_IMAGE_LAYOUT_UNDEFINED};
          fail("no image for '" + name + "'");
        });
    f.object_sets.push_back(set);
  }

  // The shadow maps this layout samples, rendered by the ShadowCaster pass.
  auto render_atlas = [&](const Texture& target, const std::vector<ShadowView>& views, bool punctual) {
    SelectedVariant variant = s.pack.select("ShadowCaster", punctual ? std::vector<std::string>{"_CASTING_PUNCTUAL_LIGHT_SHADOW"}
                                                                      : std::vector<std::string>{});
    // A depth-only render pass over the atlas.
    const VkAttachmentDescription depth = cleared_attachment(kDepthFormat, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    VkAttachmentReference ref{0, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    VkSubpassDescription subpass{};
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpass.pDepthStencilAttachment = &ref;
    VkSubpassDependency dependency{};
    dependency.srcSubpass = 0;
    dependency.dstSubpass = VK_SUBPASS_EXTERNAL;
    dependency.srcStageMask = VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
    dependency.dstStageMask = VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT;
    dependency.srcAccessMask = VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    dependency.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT;
    VkRenderPassCreateInfo pass_info{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
    pass_info.attachmentCount = 1;
    pass_info.pAttachments = &depth;
    pass_info.subpassCount = 1;
    pass_info.pSubpasses = &subpass;
    pass_info.dependencyCount = 1;
    pass_info.pDependencies = &dependency;
    VkRenderPass pass;
    check(vkCreateRenderPass(device, &pass_info, nullptr, &pass), "vkCreateRenderPass");
    s.objects.adopt(pass);
    VkFramebufferCreateInfo fb{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
    fb.renderPass = pass;
    fb.attachmentCount = 1;
    fb.pAttachments = &target.view;
    fb.width = target.desc.width;
    fb.height = target.desc.height;
    fb.layers = 1;
    VkFramebuffer framebuffer;
    check(vkCreateFramebuffer(device, &fb, nullptr, &framebuffer), "vkCreateFramebuffer");
    s.objects.adopt(framebuffer);
    VkPipeline pipeline = make_pipeline(s.context, s.objects, variant, pass, 0, s.shadow.pipeline_layout);
    s.objects.adopt(pipeline);
    std::vector<std::vector<VkDescriptorSet>> view_sets;
    for (const ShadowView& view : views) {
      HostBuffer constants = upload_buffer(s.objects, s.data.caster_constants(view), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
      std::vector<VkDescriptorSet> sets;
      for (size_t i = 0; i < sc.objects.size(); ++i) {
        VkDescriptorSet set = allocate_set(device, s.pool, s.shadow.set_layout);
        write_set(
            device, set, s.shadow,
            [&](const std::string& name) -> VkDescriptorBufferInfo {
              if (name == "PerObject") return {s.per_object[i].buffer, 0, VK_WHOLE_SIZE};
              if (name == "ShadowCaster") return {constants.buffer, 0, VK_WHOLE_SIZE};
              if (name == "PerFrame") return {f.per_frame.buffer, 0, VK_WHOLE_SIZE};
              fail("the ShadowCaster pass binds '" + name + "', which the renderer does not provide");
            },
            [&](const std::string& name) -> VkDescriptorImageInfo {
              fail("the ShadowCaster pass binds '" + name + "', which the renderer does not provide");
            });
        sets.push_back(set);
      }
      view_sets.push_back(sets);
    }
    s.context.submit([&](VkCommandBuffer cmd) {
      VkClearValue clear{};
      clear.depthStencil = {1.0f, 0};
      VkRenderPassBeginInfo begin{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
      begin.renderPass = pass;
      begin.framebuffer = framebuffer;
      begin.renderArea = {{0, 0}, {target.desc.width, target.desc.height}};
      begin.clearValueCount = 1;
      begin.pClearValues = &clear;
      vkCmdBeginRenderPass(cmd, &begin, VK_SUBPASS_CONTENTS_INLINE);
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
      for (size_t v = 0; v < views.size(); ++v) {
        set_viewport(cmd, views[v].x, views[v].y, views[v].size, views[v].size);
        draw_objects(cmd, sc, s.sphere, s.plane, s.shadow.pipeline_layout, view_sets[v]);
      }
      vkCmdEndRenderPass(cmd);
    });
    credit_coverage(s.context, s.coverage, s.shadow, variant, "(shadow caster)");
  };
  render_atlas(f.main_atlas, f.setup.main_views, false);
  if (!s.additional_rendered) {
    s.additional_rendered = true;
    // A pack stripped of punctual shadow casters (a scene profile without light shadows) has no Forward
    // variant that samples the atlas either; it stays cleared (fully lit).
    if (f.setup.additional_views.empty() || !s.data.has_punctual_caster()) {
      // No shadowed light: a cleared (fully lit) atlas still has to be bound.
      s.context.submit([&](VkCommandBuffer cmd) {
        image_barrier(cmd, s.additional_atlas.image, VK_IMAGE_ASPECT_DEPTH_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, VK_ACCESS_TRANSFER_WRITE_BIT,
                      VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
        VkClearDepthStencilValue one{1.0f, 0};
        VkImageSubresourceRange range{VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, 1};
        vkCmdClearDepthStencilImage(cmd, s.additional_atlas.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &one, 1, &range);
        image_barrier(cmd, s.additional_atlas.image, VK_IMAGE_ASPECT_DEPTH_BIT, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                      VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT,
                      VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT);
      });
    } else {
      render_atlas(s.additional_atlas, f.setup.additional_views, true);
    }
  }
  return f.setup;
}

VkPipeline SceneRenderer::image_pipeline(const SelectedVariant& variant, VkPipelineLayout layout) {
  State& s = *state_;
  const StageView* vs = variant.stage("vertex");
  const StageView* fs = variant.stage("fragment");
  auto same = [&](const State::CachedPipeline& c) {
    return vs && fs && c.pass == variant.pass && c.vertex == vs->spirv && c.fragment == fs->spirv &&
           c.vertex_entry == vs->entry_point && c.fragment_entry == fs->entry_point && c.constants == constants_of(variant);
  };
  auto found = std::find_if(s.pipelines.begin(), s.pipelines.end(), same);
  if (found != s.pipelines.end()) {
    s.pipelines.splice(s.pipelines.begin(), s.pipelines, found);
    ++pipelines_reused_;
    return found->pipeline;
  }
  State::CachedPipeline entry;
  entry.objects = std::make_unique<VulkanObjects>(s.context);
  entry.pipeline = make_pipeline(s.context, *entry.objects, variant, s.color_target.pass, 1, layout);
  entry.objects->adopt(entry.pipeline);
  entry.pass = variant.pass;
  entry.vertex = vs->spirv;
  entry.fragment = fs->spirv;
  entry.vertex_entry = vs->entry_point;
  entry.fragment_entry = fs->entry_point;
  entry.constants = constants_of(variant);
  ++pipelines_created_;
  s.pipelines.push_front(std::move(entry));
  if (s.pipelines.size() > State::kCachedPipelines) s.pipelines.pop_back();
  return s.pipelines.front().pipeline;
}

Image SceneRenderer::render(const std::vector<std::string>& keywords) {
  return render(state_->pack.select("Forward", keywords));
}

Image SceneRenderer::render(const SelectedVariant& variant) {
  State& s = *state_;
  if (variant.pass == "ShadowCaster") render_error(DiagId::VerifyArgument, "the ShadowCaster pass draws shadow maps, not images");
  frame(cascades_for(variant.keywords, scene_));
  State::Frame& f = s.frames[cascades_for(variant.keywords, scene_)];
  const PassLayout* layout = &s.forward;
  const std::vector<VkDescriptorSet>* sets = &f.object_sets;
  if (variant.pass != "Forward") {
    // A pass that reads only the frame, material and object constants (DepthOnly, DepthNormals).
    auto [it, inserted] = s.simple_passes.try_emplace(variant.pass);
    if (inserted) {
      it->second.layout = make_pass_layout(s.context, s.objects, find_pass(s.pack, variant.pass));
      for (size_t i = 0; i < scene_.objects.size(); ++i) {
        VkDescriptorSet set = allocate_set(s.context.device(), s.pool, it->second.layout.set_layout);
        write_set(
            s.context.device(), set, it->second.layout,
            [&](const std::string& name) {
              if (name == "PerFrame" || name == "PerMaterial" || name == "PerObject") return s.buffer_info(name, i, f);
              fail("the " + variant.pass + " pass binds '" + name + "', which the renderer does not provide");
            },
            [&](const std::string& name) -> VkDescriptorImageInfo {
              fail("the " + variant.pass + " pass binds '" + name + "', which the renderer does not provide");
            });
        it->second.object_sets.push_back(set);
      }
    }
    layout = &it->second.layout;
    sets = &it->second.object_sets;
  }
  if (has(variant.keywords, "_HALF_PRECISION") && !s.context.supports_float16())
    render_error(DiagId::DeviceUnavailable, "this lavapipe lacks shaderFloat16, needed by _HALF_PRECISION variants");
  auto t0 = std::chrono::steady_clock::now();
  VkPipeline pipeline = image_pipeline(variant, layout->pipeline_layout);
  last_pipeline_ms_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  write_keyword_block(*layout, variant);  // read by this draw only: submit waits for it
  s.context.submit(
      [&](VkCommandBuffer cmd) {
        VkClearValue clears[2]{};
        clears[1].depthStencil = {1.0f, 0};
        VkRenderPassBeginInfo begin{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
        begin.renderPass = s.color_target.pass;
        begin.framebuffer = s.color_target.framebuffer;
        begin.renderArea = {{0, 0}, {width_, height_}};
        begin.clearValueCount = 2;
        begin.pClearValues = clears;
        vkCmdBeginRenderPass(cmd, &begin, VK_SUBPASS_CONTENTS_INLINE);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
        set_viewport(cmd, 0, 0, width_, height_);
        draw_objects(cmd, scene_, s.sphere, s.plane, layout->pipeline_layout, *sets);
        vkCmdEndRenderPass(cmd);
      },
      &last_draw_ms_);
  credit_coverage(s.context, s.coverage, *layout, variant);
  return read_color(s.context, s.readback, s.color_target.colors[0].image, width_, height_);
}

GBuffer SceneRenderer::render_gbuffer(const PackReader& debug_pack) {
  State& s = *state_;
  frame(1);
  State::Frame& f = s.frames[1];
  VkDevice device = s.context.device();
  VulkanObjects local(s.context);
  const ManifestPass& pass = find_pass(debug_pack, "GBuffer");
  PassLayout layout = make_pass_layout(s.context, local, pass);
  Target target = make_target(s.context, local, width_, height_, kGBufferTargets, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL);
  VkPipeline pipeline = make_pipeline(s.context, local, debug_pack.select("GBuffer", {}), target.pass, kGBufferTargets,
                                      layout.pipeline_layout);
  local.adopt(pipeline);
  std::vector<VkDescriptorSet> sets;
  for (size_t i = 0; i < scene_.objects.size(); ++i) {
    VkDescriptorSet set = allocate_set(device, s.pool, layout.set_layout);
    write_set(
        device, set, layout,
        [&](const std::string& name) -> VkDescriptorBufferInfo {
          if (name == "PerFrame" || name == "PerMaterial" || name == "PerObject") return s.buffer_info(name, i, f);
          fail("the GBuffer pass binds '" + name + "', which the renderer does not provide");
        },
        [&](const std::string& name) -> VkDescriptorImageInfo {
          fail("the GBuffer pass binds '" + name + "', which the renderer does not provide");
        });
    sets.push_back(set);
  }
  s.context.submit([&](VkCommandBuffer cmd) {
    VkClearValue clears[kGBufferTargets + 1]{};
    clears[kGBufferTargets].depthStencil = {1.0f, 0};
    VkRenderPassBeginInfo begin{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
    begin.renderPass = target.pass;
    begin.framebuffer = target.framebuffer;
    begin.renderArea = {{0, 0}, {width_, height_}};
    begin.clearValueCount = kGBufferTargets + 1;
    begin.pClearValues = clears;
    vkCmdBeginRenderPass(cmd, &begin, VK_SUBPASS_CONTENTS_INLINE);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
    set_viewport(cmd, 0, 0, width_, height_);
    draw_objects(cmd, scene_, s.sphere, s.plane, layout.pipeline_layout, sets);
    vkCmdEndRenderPass(cmd);
  });
  GBuffer g;
  Image* outputs[kGBufferTargets] = {&g.position, &g.normal, &g.tangent, &g.material0, &g.material1};
  for (uint32_t i = 0; i < kGBufferTargets; ++i)
    *outputs[i] = read_color(s.context, s.readback, target.colors[i].image, width_, height_);
  return g;
}

namespace {

ShadowAtlas read_depth(VulkanContext& context, VulkanObjects& objects, VkImage image, uint32_t width, uint32_t height) {
  HostBuffer buffer = objects.host_buffer(size_t(width) * height * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  context.submit([&](VkCommandBuffer cmd) {
    image_barrier(cmd, image, VK_IMAGE_ASPECT_DEPTH_BIT, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                  VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_ACCESS_SHADER_READ_BIT, VK_ACCESS_TRANSFER_READ_BIT,
                  VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
    VkBufferImageCopy copy{};
    copy.imageSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 0, 1};
    copy.imageExtent = {width, height, 1};
    vkCmdCopyImageToBuffer(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, buffer.buffer, 1, &copy);
    image_barrier(cmd, image, VK_IMAGE_ASPECT_DEPTH_BIT, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                  VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_ACCESS_TRANSFER_READ_BIT, VK_ACCESS_SHADER_READ_BIT,
                  VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT);
  });
  ShadowAtlas atlas{width, height, std::vector<float>(size_t(width) * height)};
  std::memcpy(atlas.depth.data(), buffer.mapped, atlas.depth.size() * 4);
  return atlas;
}

}  // namespace

ShadowAtlas SceneRenderer::main_shadow_atlas(int cascades) {
  const FrameSetup& setup = frame(cascades);
  VulkanObjects local(state_->context);
  return read_depth(state_->context, local, state_->frames[cascades].main_atlas.image, setup.main_atlas_size,
                    setup.main_atlas_size);
}

ShadowAtlas SceneRenderer::additional_shadow_atlas() {
  frame(1);
  VulkanObjects local(state_->context);
  const ImageDesc& d = state_->additional_atlas.desc;
  return read_depth(state_->context, local, state_->additional_atlas.image, d.width, d.height);
}

}  // namespace kiln::render
