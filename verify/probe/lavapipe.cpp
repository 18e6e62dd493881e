// SPDX-License-Identifier: Apache-2.0
#include "probe/lavapipe.hpp"
#include "scene/verify_error.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include <glslang/SPIRV/GLSL.std.450.h>
#include <glslang/SPIRV/spirv.hpp>

#include "frontend/frontend.hpp"
#include "optimize/spirv_tools.hpp"
#include "render/vulkan_context.hpp"

namespace kiln::gpu {
namespace {

using render::check;
using render::HostBuffer;
using render::ImageDesc;
using render::VulkanObjects;

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

struct Lavapipe::State {
  std::unique_ptr<render::VulkanContext> context;
};

Lavapipe::Lavapipe(std::unique_ptr<State> state) : state_(std::move(state)) {}
Lavapipe::~Lavapipe() = default;

Result<std::unique_ptr<Lavapipe>> Lavapipe::open() {
  Result<std::unique_ptr<render::VulkanContext>> context = render::VulkanContext::open_lavapipe();
  if (!context) return failure(context.error());
  auto state = std::make_unique<State>();
  state->context = std::move(*context);
  return std::unique_ptr<Lavapipe>(new Lavapipe(std::move(state)));
}

std::string Lavapipe::device_name() const { return state_->context->device_name(); }
std::string Lavapipe::driver_info() const { return state_->context->driver_info(); }
bool Lavapipe::supports_float16() const { return state_->context->supports_float16(); }

namespace {

VkFormat vk_format(ProbeTexture::Format format) {
  switch (format) {
    case ProbeTexture::Format::Rg32f: return VK_FORMAT_R32G32_SFLOAT;
    case ProbeTexture::Format::Rg16Unorm: return VK_FORMAT_R16G16_UNORM;
    case ProbeTexture::Format::Rg8Unorm: return VK_FORMAT_R8G8_UNORM;
  }
  return VK_FORMAT_R32G32_SFLOAT;
}

// Texel bytes in the target format: unorm formats round to nearest, as an asset pipeline would.
std::vector<uint8_t> encode_texels(const ProbeTexture& texture) {
  std::vector<uint8_t> bytes;
  for (float v : texture.texels) {
    float c = std::clamp(v, 0.0f, 1.0f);
    switch (texture.format) {
      case ProbeTexture::Format::Rg32f: {
        uint8_t raw[4];
        std::memcpy(raw, &v, 4);
        bytes.insert(bytes.end(), raw, raw + 4);
        break;
      }
      case ProbeTexture::Format::Rg16Unorm: {
        auto q = static_cast<uint16_t>(std::lround(c * 65535.0f));
        bytes.push_back(static_cast<uint8_t>(q & 0xff));
        bytes.push_back(static_cast<uint8_t>(q >> 8));
        break;
      }
      case ProbeTexture::Format::Rg8Unorm: bytes.push_back(static_cast<uint8_t>(std::lround(c * 255.0f))); break;
    }
  }
  return bytes;
}

}  // namespace

std::vector<ProbeOutput> Lavapipe::run(const ProbeProgram& program, const std::vector<ProbeInput>& inputs,
                                       const std::optional<ProbeTexture>& texture, double* milliseconds,
                                       const std::vector<ProbeBuffer>& buffers) {
  if (inputs.empty()) return {};
  render::VulkanContext& context = *state_->context;
  if (program.float16 && !context.supports_float16()) render::fail(DiagId::DeviceUnavailable, {}, "the lavapipe device lacks shaderFloat16");
  VkDevice device = context.device();
  VulkanObjects objects(context);

  const uint32_t width = kProbeWidth;
  const uint32_t height = static_cast<uint32_t>((inputs.size() + width - 1) / width);
  const size_t records = size_t(width) * height;

  // Input records, padded with the last one so that every pixel reads a valid record.
  HostBuffer input = objects.host_buffer(records * sizeof(ProbeInput), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  auto* records_out = static_cast<ProbeInput*>(input.mapped);
  for (size_t i = 0; i < records; ++i) records_out[i] = inputs[std::min(i, inputs.size() - 1)];
  HostBuffer readback = objects.host_buffer(records * sizeof(ProbeOutput), VK_BUFFER_USAGE_TRANSFER_DST_BIT);

  std::vector<HostBuffer> extra;
  for (const ProbeBuffer& b : buffers) {
    extra.push_back(objects.host_buffer(
        b.bytes.size(), b.uniform ? VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT : VK_BUFFER_USAGE_STORAGE_BUFFER_BIT));
    std::memcpy(extra.back().mapped, b.bytes.data(), b.bytes.size());
  }

  ImageDesc color_desc{VK_FORMAT_R32G32B32A32_SFLOAT, width, height};
  color_desc.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  VkImage color = objects.image(color_desc);
  VkImageView color_view = objects.view(color, color_desc);

  // Optional texture (uploaded through a staging buffer).
  ImageDesc texture_desc;
  VkImage texture_image = VK_NULL_HANDLE;
  VkImageView texture_view = VK_NULL_HANDLE;
  VkSampler sampler = VK_NULL_HANDLE;
  HostBuffer staging;
  if (texture) {
    std::vector<uint8_t> bytes = encode_texels(*texture);
    staging = objects.host_buffer(bytes.size(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
    std::memcpy(staging.mapped, bytes.data(), bytes.size());
    texture_desc = {vk_format(texture->format), texture->width, texture->height};
    texture_desc.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    texture_image = objects.image(texture_desc);
    texture_view = objects.view(texture_image, texture_desc);
    VkSamplerCreateInfo info{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
    info.magFilter = VK_FILTER_LINEAR;
    info.minFilter = VK_FILTER_LINEAR;
    info.mipmapMode = VK_SAMPLER_MIPMAP_MODE_LINEAR;
    info.addressModeU = info.addressModeV = info.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    info.maxLod = 0.0f;
    sampler = objects.sampler(info);
  }

  VkAttachmentDescription attachment{};
  attachment.format = color_desc.format;
  attachment.samples = VK_SAMPLE_COUNT_1_BIT;
  attachment.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  attachment.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  attachment.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  attachment.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  attachment.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  attachment.finalLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  VkAttachmentReference reference{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  VkSubpassDescription subpass{};
  subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  subpass.colorAttachmentCount = 1;
  subpass.pColorAttachments = &reference;
  VkRenderPassCreateInfo pass_info{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
  pass_info.attachmentCount = 1;
  pass_info.pAttachments = &attachment;
  pass_info.subpassCount = 1;
  pass_info.pSubpasses = &subpass;
  VkRenderPass render_pass;
  check(vkCreateRenderPass(device, &pass_info, nullptr, &render_pass), "vkCreateRenderPass");
  objects.adopt(render_pass);
  VkFramebufferCreateInfo framebuffer_info{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
  framebuffer_info.renderPass = render_pass;
  framebuffer_info.attachmentCount = 1;
  framebuffer_info.pAttachments = &color_view;
  framebuffer_info.width = width;
  framebuffer_info.height = height;
  framebuffer_info.layers = 1;
  VkFramebuffer framebuffer;
  check(vkCreateFramebuffer(device, &framebuffer_info, nullptr, &framebuffer), "vkCreateFramebuffer");
  objects.adopt(framebuffer);

  std::vector<VkDescriptorSetLayoutBinding> bindings;
  bindings.push_back({kProbeInputBinding, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr});
  if (texture) {
    bindings.push_back({texture->binding, VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr});
    bindings.push_back({texture->sampler_binding, VK_DESCRIPTOR_TYPE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr});
  }
  auto buffer_type = [](const ProbeBuffer& b) {
    return b.uniform ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  };
  for (const ProbeBuffer& b : buffers)
    bindings.push_back({b.binding, buffer_type(b), 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr});
  VkDescriptorSetLayoutCreateInfo set_info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  set_info.bindingCount = static_cast<uint32_t>(bindings.size());
  set_info.pBindings = bindings.data();
  VkDescriptorSetLayout set_layout;
  check(vkCreateDescriptorSetLayout(device, &set_info, nullptr, &set_layout), "vkCreateDescriptorSetLayout");
  objects.adopt(set_layout);
  VkPipelineLayoutCreateInfo layout_info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  layout_info.setLayoutCount = 1;
  layout_info.pSetLayouts = &set_layout;
  VkPipelineLayout pipeline_layout;
  check(vkCreatePipelineLayout(device, &layout_info, nullptr, &pipeline_layout), "vkCreatePipelineLayout");
  objects.adopt(pipeline_layout);

  render::GraphicsPipelineDesc desc;
  desc.vertex = objects.shader_module(program.vertex);
  desc.vertex_entry = "ProbeVertex";
  desc.fragment = objects.shader_module(program.fragment);
  desc.fragment_entry = "ProbeFragment";
  desc.fixed_viewport = VkExtent2D{width, height};
  desc.layout = pipeline_layout;
  desc.render_pass = render_pass;
  VkPipeline pipeline = render::create_graphics_pipeline(device, desc);
  objects.adopt(pipeline);

  const auto buffer_count = static_cast<uint32_t>(buffers.size());
  VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1 + buffer_count},
                                  {VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, 1},
                                  {VK_DESCRIPTOR_TYPE_SAMPLER, 1},
                                  {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1 + buffer_count}};
  VkDescriptorPoolCreateInfo pool_info{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  pool_info.maxSets = 1;
  pool_info.poolSizeCount = 4;
  pool_info.pPoolSizes = sizes;
  VkDescriptorPool descriptor_pool;
  check(vkCreateDescriptorPool(device, &pool_info, nullptr, &descriptor_pool), "vkCreateDescriptorPool");
  objects.adopt(descriptor_pool);
  VkDescriptorSetAllocateInfo set_allocate{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  set_allocate.descriptorPool = descriptor_pool;
  set_allocate.descriptorSetCount = 1;
  set_allocate.pSetLayouts = &set_layout;
  VkDescriptorSet set;
  check(vkAllocateDescriptorSets(device, &set_allocate, &set), "vkAllocateDescriptorSets");
  VkDescriptorBufferInfo buffer_info{input.buffer, 0, VK_WHOLE_SIZE};
  VkDescriptorImageInfo image_info{VK_NULL_HANDLE, texture_view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  VkDescriptorImageInfo sampler_info{sampler, VK_NULL_HANDLE, VK_IMAGE_LAYOUT_UNDEFINED};
  std::vector<VkWriteDescriptorSet> writes(1, VkWriteDescriptorSet{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET});
  writes[0].dstSet = set;
  writes[0].dstBinding = kProbeInputBinding;
  writes[0].descriptorCount = 1;
  writes[0].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  writes[0].pBufferInfo = &buffer_info;
  if (texture) {
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = set;
    w.dstBinding = texture->binding;
    w.descriptorCount = 1;
    w.descriptorType = VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE;
    w.pImageInfo = &image_info;
    writes.push_back(w);
    w.dstBinding = texture->sampler_binding;
    w.descriptorType = VK_DESCRIPTOR_TYPE_SAMPLER;
    w.pImageInfo = &sampler_info;
    writes.push_back(w);
  }
  std::vector<VkDescriptorBufferInfo> extra_info;
  for (const HostBuffer& b : extra) extra_info.push_back({b.buffer, 0, VK_WHOLE_SIZE});
  for (size_t i = 0; i < buffers.size(); ++i) {
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = set;
    w.dstBinding = buffers[i].binding;
    w.descriptorCount = 1;
    w.descriptorType = buffer_type(buffers[i]);
    w.pBufferInfo = &extra_info[i];
    writes.push_back(w);
  }
  vkUpdateDescriptorSets(device, static_cast<uint32_t>(writes.size()), writes.data(), 0, nullptr);

  if (texture) {
    context.submit([&](VkCommandBuffer cmd) {
      render::image_barrier(cmd, texture_image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                            VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, VK_ACCESS_TRANSFER_WRITE_BIT,
                            VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
      VkBufferImageCopy region{};
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
      region.imageExtent = {texture->width, texture->height, 1};
      vkCmdCopyBufferToImage(cmd, staging.buffer, texture_image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
      render::image_barrier(cmd, texture_image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                            VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_ACCESS_TRANSFER_WRITE_BIT,
                            VK_ACCESS_SHADER_READ_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                            VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT);
    });
  }

  context.submit(
      [&](VkCommandBuffer cmd) {
        VkClearValue clear{};
        VkRenderPassBeginInfo pass_begin{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
        pass_begin.renderPass = render_pass;
        pass_begin.framebuffer = framebuffer;
        pass_begin.renderArea = VkRect2D{{0, 0}, {width, height}};
        pass_begin.clearValueCount = 1;
        pass_begin.pClearValues = &clear;
        vkCmdBeginRenderPass(cmd, &pass_begin, VK_SUBPASS_CONTENTS_INLINE);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_layout, 0, 1, &set, 0, nullptr);
        vkCmdDraw(cmd, 3, 1, 0, 0);
        vkCmdEndRenderPass(cmd);
      },
      milliseconds);

  context.submit([&](VkCommandBuffer cmd) {
    VkBufferImageCopy copy{};
    copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    copy.imageExtent = {width, height, 1};
    vkCmdCopyImageToBuffer(cmd, color, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback.buffer, 1, &copy);
  });

  const auto* values = static_cast<const ProbeOutput*>(readback.mapped);
  return std::vector<ProbeOutput>(values, values + inputs.size());
}

namespace {

// Serves #include from the include directories (the probe is test code; kiln build's includer, with its
// confinement rules, is tested elsewhere).
class DirectoryIncludes final : public IncludeSource {
 public:
  explicit DirectoryIncludes(std::vector<std::filesystem::path> dirs) : dirs_(std::move(dirs)) {}
  Result<Found> resolve(std::string_view requested, std::string_view from) const override {
    std::vector<std::filesystem::path> candidates;
    if (!from.empty()) candidates.push_back(std::filesystem::path(from).parent_path() / requested);
    for (const auto& dir : dirs_) candidates.push_back(dir / requested);
    for (const auto& candidate : candidates) {
      std::error_code ec;
      if (!std::filesystem::is_regular_file(candidate, ec)) continue;
      std::string key = std::filesystem::weakly_canonical(candidate).string();
      auto [it, inserted] = texts_.try_emplace(key);
      if (inserted) it->second = read_text(key);
      return Found{key, it->second};
    }
    return failure("cannot find '" + std::string(requested) + "'");
  }

 private:
  std::vector<std::filesystem::path> dirs_;
  mutable std::map<std::string, std::string> texts_;
};

}  // namespace

Result<ProbeProgram> compile_probe(const std::filesystem::path& probe_file, const std::vector<std::filesystem::path>& include_dirs,
                                   const std::vector<std::string>& defines, bool optimize) {
  auto frontend = make_glslang_frontend();
  DirectoryIncludes includes(include_dirs);
  std::string entry_text = read_text(probe_file);
  std::string entry_name = std::filesystem::weakly_canonical(probe_file).string();
  ProbeProgram program;
  for (Stage stage : {Stage::Vertex, Stage::Fragment}) {
    PreprocessRequest request{stage, entry_name, entry_text, defines, &includes};
    PreprocessResult preprocessed = frontend->preprocess(request);
    auto describe = [&](const std::vector<FrontendMessage>& messages) {
      std::string text;
      for (const auto& m : messages) text += m.path + ":" + std::to_string(m.line) + ": " + m.text + "\n";
      return text;
    };
    if (!preprocessed.ok) return failure("preprocessing " + entry_name + " failed:\n" + describe(preprocessed.messages));
    const char* entry = stage == Stage::Vertex ? "ProbeVertex" : "ProbeFragment";
    CompileResult compiled = frontend->compile({stage, entry, entry_name, preprocessed.text});
    if (!compiled.ok)
      return failure("compiling " + entry_name + " (" + std::string(stage_name(stage)) + ") failed:\n" + describe(compiled.messages));
    SpirvResult steps = legalize_validate_optimize(std::move(compiled.spirv), optimize);
    if (!steps) {
      std::string error = std::string(step_name(steps.error().step)) + " failed for " + entry_name + ":";
      for (const auto& m : steps.error().messages) error += "\n" + m;
      return failure(std::move(error));
    }
    (stage == Stage::Vertex ? program.vertex : program.fragment) = std::move(steps->spirv);
  }
  program.float16 = std::find(defines.begin(), defines.end(), "_HALF_PRECISION") != defines.end();
  return program;
}

ShaderCost weighted_cost(const std::vector<uint32_t>& spirv) {
  ShaderCost cost;
  if (spirv.size() < 5) return cost;
  std::map<uint32_t, uint32_t> components;  // type id -> scalar count
  uint32_t glsl_set = UINT32_MAX;
  bool in_function = false;
  for (size_t i = 5; i < spirv.size();) {
    uint32_t word_count = spirv[i] >> 16;
    auto op = static_cast<spv::Op>(spirv[i] & 0xffff);
    if (word_count == 0 || i + word_count > spirv.size()) break;
    const uint32_t* w = &spirv[i];
    switch (op) {
      case spv::OpExtInstImport:
        if (std::strcmp(reinterpret_cast<const char*>(&w[2]), "GLSL.std.450") == 0) glsl_set = w[1];
        break;
      case spv::OpTypeFloat:
      case spv::OpTypeInt:
      case spv::OpTypeBool: components[w[1]] = 1; break;
      case spv::OpTypeVector: components[w[1]] = w[3]; break;
      case spv::OpFunction: in_function = true; break;
      case spv::OpFunctionEnd: in_function = false; break;
      default: break;
    }
    if (in_function && word_count >= 3) {
      auto width = [&](uint32_t type) {
        auto it = components.find(type);
        return it == components.end() ? 1u : it->second;
      };
      double weight = -1;  // < 0: not an arithmetic instruction
      uint32_t n = word_count >= 2 ? width(w[1]) : 1;
      switch (op) {
        case spv::OpImageSampleImplicitLod:
        case spv::OpImageSampleExplicitLod:
        case spv::OpImageSampleDrefImplicitLod:
        case spv::OpImageSampleDrefExplicitLod:
        case spv::OpImageFetch:
        case spv::OpImageGather:
        case spv::OpImageDrefGather: ++cost.texture_fetches; break;
        case spv::OpFDiv:
        case spv::OpUDiv:
        case spv::OpSDiv:
        case spv::OpFRem:
        case spv::OpFMod: weight = 5.0 * n; break;
        case spv::OpDot: weight = 3; break;  // a 3-component dot (the library's only kind)
        case spv::OpFAdd: case spv::OpFSub: case spv::OpFMul: case spv::OpFNegate:
        case spv::OpIAdd: case spv::OpISub: case spv::OpIMul: case spv::OpSNegate:
        case spv::OpVectorTimesScalar: case spv::OpMatrixTimesScalar:
        case spv::OpFOrdLessThan: case spv::OpFOrdGreaterThan: case spv::OpFOrdLessThanEqual:
        case spv::OpFOrdGreaterThanEqual: case spv::OpFOrdEqual: case spv::OpFOrdNotEqual:
        case spv::OpFUnordLessThan: case spv::OpFUnordGreaterThan: case spv::OpFUnordLessThanEqual:
        case spv::OpFUnordGreaterThanEqual: case spv::OpFUnordEqual: case spv::OpFUnordNotEqual:
        case spv::OpULessThan: case spv::OpSLessThan: case spv::OpUGreaterThan: case spv::OpSGreaterThan:
        case spv::OpULessThanEqual: case spv::OpSLessThanEqual: case spv::OpUGreaterThanEqual:
        case spv::OpSGreaterThanEqual: case spv::OpIEqual: case spv::OpINotEqual:
        case spv::OpSelect: case spv::OpLogicalAnd: case spv::OpLogicalOr: case spv::OpLogicalNot:
        case spv::OpConvertFToU: case spv::OpConvertFToS: case spv::OpConvertSToF: case spv::OpConvertUToF:
        case spv::OpFConvert: case spv::OpBitwiseAnd: case spv::OpBitwiseOr: case spv::OpBitwiseXor:
        case spv::OpShiftLeftLogical: case spv::OpShiftRightLogical: case spv::OpShiftRightArithmetic:
          weight = n;
          break;
        case spv::OpMatrixTimesVector: case spv::OpVectorTimesMatrix: weight = 4.0 * n; break;
        case spv::OpExtInst:
          if (w[3] == glsl_set) {
            switch (static_cast<GLSLstd450>(w[4])) {
              case GLSLstd450Sqrt: case GLSLstd450InverseSqrt: case GLSLstd450Exp2: case GLSLstd450Log2:
              case GLSLstd450Exp: case GLSLstd450Log: case GLSLstd450Sin: case GLSLstd450Cos:
                weight = 4.0 * n;
                break;
              case GLSLstd450Pow: weight = 9.0 * n; break;
              case GLSLstd450Normalize: weight = 2.0 * n + 4.0; break;  // dot, rsqrt, scale
              case GLSLstd450Length: case GLSLstd450Distance: weight = n + 4.0; break;
              default: weight = n; break;  // min, max, clamp, mix, fma, abs, floor, step, ...
            }
          }
          break;
        default: break;
      }
      if (weight >= 0) {
        cost.weighted += weight;
        ++cost.instructions;
      }
    }
    i += word_count;
  }
  return cost;
}

std::string cost_weights_description() {
  return "per scalar component: add, multiply, compare, select, min/max/clamp/mix and conversions 1; dot 3;"
         " rcp, sqrt, inversesqrt, exp2, log2, exp, log, sin, cos 4; divide 5; pow 9; normalize 2n+4; "
         "length n+4; loads, stores, swizzles and branches 0; texture fetches counted separately";
}

}  // namespace kiln::gpu
