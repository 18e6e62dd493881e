// SPDX-License-Identifier: Apache-2.0
// The Vulkan device kiln runs shaders on: Mesa lavapipe (CPU Vulkan), chosen by driver ID so that a real
// GPU is never picked by accident, plus the small helpers every renderer here needs (host-visible buffers,
// images, one-shot submissions). Shared by `kiln render`, `kiln test` and the probe harness of the tests.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "kiln/result.hpp"

namespace kiln::render {

// Throws a VerifyError (K2007) naming `what` and the VkResult.
void check(VkResult result, const char* what);

class VulkanContext {
 public:
  // Opens lavapipe explicitly; the error says what is missing (loader, driver, queue).
  static Result<std::unique_ptr<VulkanContext>> open_lavapipe();
  ~VulkanContext();
  VulkanContext(const VulkanContext&) = delete;
  VulkanContext& operator=(const VulkanContext&) = delete;

  VkDevice device() const { return device_; }
  VkPhysicalDevice physical() const { return physical_; }
  bool supports_float16() const { return float16_; }
  std::string device_name() const { return properties_.deviceName; }
  std::string driver_info() const;  // e.g. "llvmpipe Mesa 22.3.6 (LLVM 15.0.6)"
  uint32_t memory_type(uint32_t type_bits, VkMemoryPropertyFlags flags) const;

  // Records commands into a fresh primary command buffer, submits, waits. `milliseconds` receives the
  // submit-to-idle wall time.
  void submit(const std::function<void(VkCommandBuffer)>& record, double* milliseconds = nullptr);

 private:
  VulkanContext() = default;
  VkInstance instance_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  uint32_t queue_family_ = 0;
  VkCommandPool pool_ = VK_NULL_HANDLE;
  VkPhysicalDeviceProperties properties_{};
  VkPhysicalDeviceDriverProperties driver_{};
  VkPhysicalDeviceMemoryProperties memory_{};
  bool float16_ = false;
};

struct HostBuffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  void* mapped = nullptr;
  VkDeviceSize size = 0;
};

struct ImageDesc {
  VkFormat format = VK_FORMAT_R32G32B32A32_SFLOAT;
  uint32_t width = 1;
  uint32_t height = 1;
  uint32_t mip_levels = 1;
  uint32_t layers = 1;  // 6 with `cube`
  bool cube = false;
  VkImageUsageFlags usage = 0;
};

// Owns the objects it creates and destroys them in reverse order of kind (views before images, ...).
class VulkanObjects {
 public:
  explicit VulkanObjects(VulkanContext& context) : context_(context) {}
  ~VulkanObjects();
  VulkanObjects(const VulkanObjects&) = delete;
  VulkanObjects& operator=(const VulkanObjects&) = delete;

  HostBuffer host_buffer(VkDeviceSize size, VkBufferUsageFlags usage);
  VkImage image(const ImageDesc& desc);
  // A view of the whole image; the aspect follows from the format (depth or color).
  VkImageView view(VkImage image, const ImageDesc& desc);
  VkSampler sampler(const VkSamplerCreateInfo& info);
  VkShaderModule shader_module(const std::vector<uint32_t>& spirv);
  VkShaderModule shader_module(const void* bytes, size_t size);
  // Objects created elsewhere, destroyed with the rest.
  void adopt(VkRenderPass pass) { render_passes_.push_back(pass); }
  void adopt(VkFramebuffer framebuffer) { framebuffers_.push_back(framebuffer); }
  void adopt(VkPipeline pipeline) { pipelines_.push_back(pipeline); }
  void adopt(VkPipelineLayout layout) { pipeline_layouts_.push_back(layout); }
  void adopt(VkDescriptorSetLayout layout) { set_layouts_.push_back(layout); }
  void adopt(VkDescriptorPool pool) { descriptor_pools_.push_back(pool); }

 private:
  VulkanContext& context_;
  std::vector<VkBuffer> buffers_;
  std::vector<VkImage> images_;
  std::vector<VkImageView> views_;
  std::vector<VkDeviceMemory> memories_;
  std::vector<VkSampler> samplers_;
  std::vector<VkShaderModule> modules_;
  std::vector<VkRenderPass> render_passes_;
  std::vector<VkFramebuffer> framebuffers_;
  std::vector<VkPipeline> pipelines_;
  std::vector<VkPipelineLayout> pipeline_layouts_;
  std::vector<VkDescriptorSetLayout> set_layouts_;
  std::vector<VkDescriptorPool> descriptor_pools_;
};

bool is_depth_format(VkFormat format);

// A graphics pipeline as kiln's renderers build them: triangle lists, no culling (shaders handle back faces
// through SV_IsFrontFace), one sample, every colour target written without blending. The fields say what
// differs between the scene renderer and the probe harness of the tests.
struct GraphicsPipelineDesc {
  VkShaderModule vertex = VK_NULL_HANDLE;
  const char* vertex_entry = "main";
  VkShaderModule fragment = VK_NULL_HANDLE;
  const char* fragment_entry = "main";
  // Specialization constants of each stage (a folded pack's keywords); null: none.
  const VkSpecializationInfo* vertex_specialization = nullptr;
  const VkSpecializationInfo* fragment_specialization = nullptr;
  std::vector<VkVertexInputBindingDescription> vertex_bindings;
  std::vector<VkVertexInputAttributeDescription> vertex_attributes;
  uint32_t color_targets = 1;
  bool depth = false;                       // depth test and write, LESS (the render pass has a depth attachment)
  std::optional<VkExtent2D> fixed_viewport;  // otherwise viewport and scissor are dynamic state
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkRenderPass render_pass = VK_NULL_HANDLE;
};

// The caller owns the pipeline (VulkanObjects::adopt).
VkPipeline create_graphics_pipeline(VkDevice device, const GraphicsPipelineDesc& desc);

// A layout transition of every subresource of `image`.
void image_barrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, VkImageLayout from, VkImageLayout to,
                   VkAccessFlags src_access, VkAccessFlags dst_access, VkPipelineStageFlags src_stage,
                   VkPipelineStageFlags dst_stage);

}  // namespace kiln::render
