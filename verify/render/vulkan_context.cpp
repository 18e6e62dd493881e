// SPDX-License-Identifier: Apache-2.0
#include "render/vulkan_context.hpp"
#include "scene/verify_error.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>

namespace kiln::render {

void check(VkResult result, const char* what) {
  if (result != VK_SUCCESS) fail(DiagId::DriverCallFailed, {}, std::string(what) + " failed: VkResult " + std::to_string(result));
}

Result<std::unique_ptr<VulkanContext>> VulkanContext::open_lavapipe() {
  std::unique_ptr<VulkanContext> context(new VulkanContext());
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "kiln";
  app.apiVersion = VK_API_VERSION_1_2;
  VkInstanceCreateInfo instance_info{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  instance_info.pApplicationInfo = &app;
  if (vkCreateInstance(&instance_info, nullptr, &context->instance_) != VK_SUCCESS) {
    return failure("cannot create a Vulkan instance (is the Vulkan loader installed? Debian: libvulkan1 mesa-vulkan-drivers)");
  }
  uint32_t count = 0;
  vkEnumeratePhysicalDevices(context->instance_, &count, nullptr);
  std::vector<VkPhysicalDevice> devices(count);
  vkEnumeratePhysicalDevices(context->instance_, &count, devices.data());
  for (VkPhysicalDevice candidate : devices) {
    VkPhysicalDeviceDriverProperties driver{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
    VkPhysicalDeviceProperties2 properties{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    properties.pNext = &driver;
    vkGetPhysicalDeviceProperties2(candidate, &properties);
    if (driver.driverID == VK_DRIVER_ID_MESA_LLVMPIPE) {
      context->physical_ = candidate;
      context->properties_ = properties.properties;
      context->driver_ = driver;
      context->driver_.pNext = nullptr;
      break;
    }
  }
  if (!context->physical_) {
    return failure("no lavapipe device among " + std::to_string(count) +
            " Vulkan device(s): install Debian's mesa-vulkan-drivers (kiln runs shaders on lavapipe only)");
  }
  vkGetPhysicalDeviceMemoryProperties(context->physical_, &context->memory_);

  VkPhysicalDeviceVulkan12Features supported12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  VkPhysicalDeviceFeatures2 supported{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  supported.pNext = &supported12;
  vkGetPhysicalDeviceFeatures2(context->physical_, &supported);
  context->float16_ = supported12.shaderFloat16 == VK_TRUE;

  uint32_t families = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(context->physical_, &families, nullptr);
  std::vector<VkQueueFamilyProperties> family_properties(families);
  vkGetPhysicalDeviceQueueFamilyProperties(context->physical_, &families, family_properties.data());
  auto graphics = std::find_if(family_properties.begin(), family_properties.end(),
                               [](const VkQueueFamilyProperties& f) { return f.queueFlags & VK_QUEUE_GRAPHICS_BIT; });
  if (graphics == family_properties.end()) {
    return failure("the lavapipe device has no graphics queue");
  }
  context->queue_family_ = static_cast<uint32_t>(graphics - family_properties.begin());

  float priority = 1.0f;
  VkDeviceQueueCreateInfo queue_info{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  queue_info.queueFamilyIndex = context->queue_family_;
  queue_info.queueCount = 1;
  queue_info.pQueuePriorities = &priority;
  VkPhysicalDeviceVulkan12Features enabled12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  enabled12.shaderFloat16 = supported12.shaderFloat16;
  VkPhysicalDeviceFeatures2 enabled{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  enabled.pNext = &enabled12;
  // A --coverage pack's stages write their coverage buffer (kiln/coverage_map.hpp).
  enabled.features.vertexPipelineStoresAndAtomics = supported.features.vertexPipelineStoresAndAtomics;
  enabled.features.fragmentStoresAndAtomics = supported.features.fragmentStoresAndAtomics;
  VkDeviceCreateInfo device_info{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  device_info.pNext = &enabled;
  device_info.queueCreateInfoCount = 1;
  device_info.pQueueCreateInfos = &queue_info;
  if (vkCreateDevice(context->physical_, &device_info, nullptr, &context->device_) != VK_SUCCESS) {
    return failure("cannot create the lavapipe logical device");
  }
  vkGetDeviceQueue(context->device_, context->queue_family_, 0, &context->queue_);
  VkCommandPoolCreateInfo pool_info{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pool_info.queueFamilyIndex = context->queue_family_;
  pool_info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  if (vkCreateCommandPool(context->device_, &pool_info, nullptr, &context->pool_) != VK_SUCCESS) {
    return failure("cannot create a command pool");
  }
  return context;
}

VulkanContext::~VulkanContext() {
  if (device_) {
    vkDeviceWaitIdle(device_);
    if (pool_) vkDestroyCommandPool(device_, pool_, nullptr);
    vkDestroyDevice(device_, nullptr);
  }
  if (instance_) vkDestroyInstance(instance_, nullptr);
}

std::string VulkanContext::driver_info() const {
  return std::string(driver_.driverName) + " " + driver_.driverInfo;
}

uint32_t VulkanContext::memory_type(uint32_t type_bits, VkMemoryPropertyFlags flags) const {
  for (uint32_t i = 0; i < memory_.memoryTypeCount; ++i)
    if ((type_bits & (1u << i)) && (memory_.memoryTypes[i].propertyFlags & flags) == flags) return i;
  fail(DiagId::DriverCallFailed, {}, "no Vulkan memory type with the requested properties");
}

void VulkanContext::submit(const std::function<void(VkCommandBuffer)>& record, double* milliseconds) {
  VkCommandBufferAllocateInfo command_info{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  command_info.commandPool = pool_;
  command_info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  command_info.commandBufferCount = 1;
  VkCommandBuffer cmd;
  check(vkAllocateCommandBuffers(device_, &command_info, &cmd), "vkAllocateCommandBuffers");
  struct FreeCommand {
    VkDevice d;
    VkCommandPool p;
    VkCommandBuffer c;
    ~FreeCommand() { vkFreeCommandBuffers(d, p, 1, &c); }
  } free_command{device_, pool_, cmd};
  VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer");
  record(cmd);
  check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
  VkSubmitInfo submit_info{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  submit_info.commandBufferCount = 1;
  submit_info.pCommandBuffers = &cmd;
  auto t0 = std::chrono::steady_clock::now();
  check(vkQueueSubmit(queue_, 1, &submit_info, VK_NULL_HANDLE), "vkQueueSubmit");
  check(vkQueueWaitIdle(queue_), "vkQueueWaitIdle");
  if (milliseconds)
    *milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

VulkanObjects::~VulkanObjects() {
  VkDevice d = context_.device();
  vkDeviceWaitIdle(d);
  for (auto p : descriptor_pools_) vkDestroyDescriptorPool(d, p, nullptr);
  for (auto p : pipelines_) vkDestroyPipeline(d, p, nullptr);
  for (auto l : pipeline_layouts_) vkDestroyPipelineLayout(d, l, nullptr);
  for (auto l : set_layouts_) vkDestroyDescriptorSetLayout(d, l, nullptr);
  for (auto m : modules_) vkDestroyShaderModule(d, m, nullptr);
  for (auto f : framebuffers_) vkDestroyFramebuffer(d, f, nullptr);
  for (auto r : render_passes_) vkDestroyRenderPass(d, r, nullptr);
  for (auto s : samplers_) vkDestroySampler(d, s, nullptr);
  for (auto v : views_) vkDestroyImageView(d, v, nullptr);
  for (auto i : images_) vkDestroyImage(d, i, nullptr);
  for (auto b : buffers_) vkDestroyBuffer(d, b, nullptr);
  for (auto m : memories_) vkFreeMemory(d, m, nullptr);
}

HostBuffer VulkanObjects::host_buffer(VkDeviceSize size, VkBufferUsageFlags usage) {
  VkDevice d = context_.device();
  VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = std::max<VkDeviceSize>(size, 16);
  info.usage = usage;
  HostBuffer result;
  result.size = info.size;
  check(vkCreateBuffer(d, &info, nullptr, &result.buffer), "vkCreateBuffer");
  buffers_.push_back(result.buffer);
  VkMemoryRequirements requirements;
  vkGetBufferMemoryRequirements(d, result.buffer, &requirements);
  VkMemoryAllocateInfo allocate{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  allocate.allocationSize = requirements.size;
  allocate.memoryTypeIndex = context_.memory_type(
      requirements.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
  VkDeviceMemory memory;
  check(vkAllocateMemory(d, &allocate, nullptr, &memory), "vkAllocateMemory");
  memories_.push_back(memory);
  check(vkBindBufferMemory(d, result.buffer, memory, 0), "vkBindBufferMemory");
  check(vkMapMemory(d, memory, 0, info.size, 0, &result.mapped), "vkMapMemory");
  return result;
}

bool is_depth_format(VkFormat format) {
  return format == VK_FORMAT_D32_SFLOAT || format == VK_FORMAT_D16_UNORM || format == VK_FORMAT_D24_UNORM_S8_UINT ||
         format == VK_FORMAT_D32_SFLOAT_S8_UINT;
}

VkImage VulkanObjects::image(const ImageDesc& desc) {
  VkDevice d = context_.device();
  VkImageCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  info.flags = desc.cube ? VK_IMAGE_CREATE_CUBE_COMPATIBLE_BIT : 0;
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = desc.format;
  info.extent = {desc.width, desc.height, 1};
  info.mipLevels = desc.mip_levels;
  info.arrayLayers = desc.layers;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = desc.usage;
  info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VkImage image;
  check(vkCreateImage(d, &info, nullptr, &image), "vkCreateImage");
  images_.push_back(image);
  VkMemoryRequirements requirements;
  vkGetImageMemoryRequirements(d, image, &requirements);
  VkMemoryAllocateInfo allocate{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  allocate.allocationSize = requirements.size;
  allocate.memoryTypeIndex = context_.memory_type(requirements.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  VkDeviceMemory memory;
  check(vkAllocateMemory(d, &allocate, nullptr, &memory), "vkAllocateMemory");
  memories_.push_back(memory);
  check(vkBindImageMemory(d, image, memory, 0), "vkBindImageMemory");
  return image;
}

VkImageView VulkanObjects::view(VkImage image, const ImageDesc& desc) {
  VkImageViewCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  info.image = image;
  info.viewType = desc.cube ? VK_IMAGE_VIEW_TYPE_CUBE : VK_IMAGE_VIEW_TYPE_2D;
  info.format = desc.format;
  VkImageAspectFlags aspect = is_depth_format(desc.format) ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT;
  info.subresourceRange = {aspect, 0, desc.mip_levels, 0, desc.layers};
  VkImageView view;
  check(vkCreateImageView(context_.device(), &info, nullptr, &view), "vkCreateImageView");
  views_.push_back(view);
  return view;
}

VkSampler VulkanObjects::sampler(const VkSamplerCreateInfo& info) {
  VkSampler sampler;
  check(vkCreateSampler(context_.device(), &info, nullptr, &sampler), "vkCreateSampler");
  samplers_.push_back(sampler);
  return sampler;
}

VkShaderModule VulkanObjects::shader_module(const void* bytes, size_t size) {
  if (size == 0 || size % 4 != 0) fail(DiagId::PackUnusable, {}, "a SPIR-V blob of " + std::to_string(size) + " bytes (not a whole number of words)");
  std::vector<uint32_t> words(size / 4);
  std::copy_n(static_cast<const uint8_t*>(bytes), size, reinterpret_cast<uint8_t*>(words.data()));
  return shader_module(words);
}

VkShaderModule VulkanObjects::shader_module(const std::vector<uint32_t>& spirv) {
  VkShaderModuleCreateInfo info{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  info.codeSize = spirv.size() * sizeof(uint32_t);
  info.pCode = spirv.data();
  VkShaderModule module;
  check(vkCreateShaderModule(context_.device(), &info, nullptr, &module), "vkCreateShaderModule");
  modules_.push_back(module);
  return module;
}

void image_barrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, VkImageLayout from, VkImageLayout to,
                   VkAccessFlags src_access, VkAccessFlags dst_access, VkPipelineStageFlags src_stage,
                   VkPipelineStageFlags dst_stage) {
  VkImageMemoryBarrier b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
  b.oldLayout = from;
  b.newLayout = to;
  b.srcAccessMask = src_access;
  b.dstAccessMask = dst_access;
  b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {aspect, 0, VK_REMAINING_MIP_LEVELS, 0, VK_REMAINING_ARRAY_LAYERS};
  vkCmdPipelineBarrier(cmd, src_stage, dst_stage, 0, 0, nullptr, 0, nullptr, 1, &b);
}

VkPipeline create_graphics_pipeline(VkDevice device, const GraphicsPipelineDesc& desc) {
  VkPipelineShaderStageCreateInfo stages[2]{};
  stages[0].sType = stages[1].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[0].module = desc.vertex;
  stages[0].pName = desc.vertex_entry;
  stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  stages[1].module = desc.fragment;
  stages[1].pName = desc.fragment_entry;
  stages[0].pSpecializationInfo = desc.vertex_specialization;
  stages[1].pSpecializationInfo = desc.fragment_specialization;
  VkPipelineVertexInputStateCreateInfo vertex_input{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  vertex_input.vertexBindingDescriptionCount = static_cast<uint32_t>(desc.vertex_bindings.size());
  vertex_input.pVertexBindingDescriptions = desc.vertex_bindings.data();
  vertex_input.vertexAttributeDescriptionCount = static_cast<uint32_t>(desc.vertex_attributes.size());
  vertex_input.pVertexAttributeDescriptions = desc.vertex_attributes.data();
  VkPipelineInputAssemblyStateCreateInfo assembly{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkViewport viewport{};
  VkRect2D scissor{};
  VkPipelineViewportStateCreateInfo viewport_state{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  viewport_state.viewportCount = 1;
  viewport_state.scissorCount = 1;
  VkDynamicState dynamic_states[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dynamic{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  if (desc.fixed_viewport) {
    viewport = {0, 0, float(desc.fixed_viewport->width), float(desc.fixed_viewport->height), 0, 1};
    scissor = {{0, 0}, *desc.fixed_viewport};
    viewport_state.pViewports = &viewport;
    viewport_state.pScissors = &scissor;
  } else {
    dynamic.dynamicStateCount = 2;
    dynamic.pDynamicStates = dynamic_states;
  }
  VkPipelineRasterizationStateCreateInfo raster{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  raster.polygonMode = VK_POLYGON_MODE_FILL;
  raster.cullMode = VK_CULL_MODE_NONE;
  raster.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo multisample{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineDepthStencilStateCreateInfo depth{VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
  depth.depthTestEnable = VK_TRUE;
  depth.depthWriteEnable = VK_TRUE;
  depth.depthCompareOp = VK_COMPARE_OP_LESS;
  std::vector<VkPipelineColorBlendAttachmentState> blends(desc.color_targets);
  for (auto& b : blends) b.colorWriteMask = 0xf;
  VkPipelineColorBlendStateCreateInfo blend_state{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  blend_state.attachmentCount = desc.color_targets;
  blend_state.pAttachments = blends.data();
  VkGraphicsPipelineCreateInfo info{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
  info.stageCount = 2;
  info.pStages = stages;
  info.pVertexInputState = &vertex_input;
  info.pInputAssemblyState = &assembly;
  info.pViewportState = &viewport_state;
  info.pRasterizationState = &raster;
  info.pMultisampleState = &multisample;
  info.pDepthStencilState = desc.depth ? &depth : nullptr;
  info.pColorBlendState = &blend_state;
  info.pDynamicState = desc.fixed_viewport ? nullptr : &dynamic;
  info.layout = desc.layout;
  info.renderPass = desc.render_pass;
  VkPipeline pipeline;
  check(vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline), "vkCreateGraphicsPipelines");
  return pipeline;
}

}  // namespace kiln::render
