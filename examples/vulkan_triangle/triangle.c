/* SPDX-License-Identifier: Apache-2.0 */
/* Draws one frame with a variant from a kiln pack, headless, and writes it as a PNG. Uses the reader's C API
 * (kiln/kiln_reader.h), Vulkan and libpng only. The pipeline comes from the pack: the variant is selected by
 * keywords, its SPIR-V and entry points are the pack's, and the descriptor set layout and vertex input are made from
 * its reflection.
 *
 * usage: vulkan_triangle PACK_DIR OUT.png [KEYWORD]...     (Triangle.hlsl: INVERT inverts the colour)
 * With KILN_USAGE_LOG=FILE in the environment it records what it selects into that usage log (docs/usage.md),
 * written when the pack is closed: `kiln build --usage FILE` then keeps just that variant. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <kiln/kiln_reader.h>
#include <png.h>
#include <vulkan/vulkan.h>

enum { kWidth = 64, kHeight = 64 };

#define VK(call)                                                        \
  do {                                                                  \
    VkResult result_ = (call);                                          \
    if (result_ != VK_SUCCESS) die("%s failed: VkResult %d", #call, result_); \
  } while (0)

static void die(const char* format, ...) __attribute__((format(printf, 1, 2), noreturn));
static void die(const char* format, ...) {
  va_list args;
  va_start(args, format);
  fprintf(stderr, "vulkan_triangle: ");
  vfprintf(stderr, format, args);
  fprintf(stderr, "\n");
  va_end(args);
  exit(1);
}

/* Vulkan's names for what the reflection says. */
static VkDescriptorType descriptor_type(kiln_resource_kind kind) {
  switch (kind) {
    case KILN_RESOURCE_UNIFORM_BUFFER: return VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    case KILN_RESOURCE_STORAGE_BUFFER: return VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    case KILN_RESOURCE_TEXTURE: return VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE;
    case KILN_RESOURCE_SAMPLER: return VK_DESCRIPTOR_TYPE_SAMPLER;
    case KILN_RESOURCE_COMBINED_IMAGE_SAMPLER: return VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    case KILN_RESOURCE_STORAGE_IMAGE: return VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
    case KILN_RESOURCE_UNIFORM_TEXEL_BUFFER: return VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
    case KILN_RESOURCE_STORAGE_TEXEL_BUFFER: return VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER;
    case KILN_RESOURCE_INPUT_ATTACHMENT: return VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT;
  }
  return VK_DESCRIPTOR_TYPE_MAX_ENUM;
}
static VkFormat vertex_format(const kiln_stage_variable* input) {
  static const VkFormat floats[] = {VK_FORMAT_R32_SFLOAT, VK_FORMAT_R32G32_SFLOAT, VK_FORMAT_R32G32B32_SFLOAT,
                                    VK_FORMAT_R32G32B32A32_SFLOAT};
  if (input->scalar != KILN_SCALAR_FLOAT || input->components < 1) die("vertex input %s: only float vectors here", input->name);
  return floats[input->components - 1];
}

static uint32_t memory_type(VkPhysicalDevice gpu, uint32_t allowed, VkMemoryPropertyFlags wanted) {
  VkPhysicalDeviceMemoryProperties memory;
  vkGetPhysicalDeviceMemoryProperties(gpu, &memory);
  for (uint32_t i = 0; i < memory.memoryTypeCount; ++i)
    if ((allowed & (1u << i)) && (memory.memoryTypes[i].propertyFlags & wanted) == wanted) return i;
  die("no suitable memory type");
}

/* A host-visible buffer, mapped. */
static VkBuffer make_buffer(VkDevice device, VkPhysicalDevice gpu, VkDeviceSize size, VkBufferUsageFlags usage,
                            VkDeviceMemory* memory, void** mapped) {
  VkBufferCreateInfo info = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO, NULL, 0, size, usage, VK_SHARING_MODE_EXCLUSIVE, 0, NULL};
  VkBuffer buffer;
  VkMemoryRequirements needs;
  VK(vkCreateBuffer(device, &info, NULL, &buffer));
  vkGetBufferMemoryRequirements(device, buffer, &needs);
  VkMemoryAllocateInfo allocate = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, NULL, needs.size,
                                   memory_type(gpu, needs.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                                                                             VK_MEMORY_PROPERTY_HOST_COHERENT_BIT)};
  VK(vkAllocateMemory(device, &allocate, NULL, memory));
  VK(vkBindBufferMemory(device, buffer, *memory, 0));
  VK(vkMapMemory(device, *memory, 0, size, 0, mapped));
  return buffer;
}

static VkShaderModule make_module(VkDevice device, kiln_code code) {
  VkShaderModuleCreateInfo info = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO, NULL, 0, code.size, code.bytes};
  VkShaderModule module;
  VK(vkCreateShaderModule(device, &info, NULL, &module));
  return module;
}

int main(int argc, char** argv) {
  if (argc < 3) die("usage: vulkan_triangle PACK_DIR OUT.png [KEYWORD]...");

  /* 1. The pack: the variant for the keywords given, its code and its reflection. */
  kiln_error error;
  kiln_pack* pack;
  kiln_pass pass;
  kiln_keyword keywords[16];
  uint32_t keyword_count = 0, variant;
  if (kiln_pack_open(argv[1], &pack, &error) != KILN_OK) die("%s: %s", error.file, error.message);
  const char* usage_log = getenv("KILN_USAGE_LOG");
  const char* usage_tags[] = {"example=vulkan_triangle"};
  if (usage_log && kiln_pack_record_usage(pack, usage_log, usage_tags, 1, &error) != KILN_OK) die("%s", error.message);
  if (kiln_pass_find(pack, "Main", &pass, &error) != KILN_OK) die("%s", error.message);
  for (int i = 3; i < argc && keyword_count < 16; ++i)
    if (kiln_keyword_find(pack, argv[i], &keywords[keyword_count++], &error) != KILN_OK) die("%s", error.message);
  if (kiln_select(pack, pass, keywords, keyword_count, 1, &variant, &error) != KILN_OK) die("%s", error.message);
  const kiln_stage stages[2] = {KILN_STAGE_VERTEX, KILN_STAGE_FRAGMENT};
  kiln_code code[2];
  for (int s = 0; s < 2; ++s)
    if (kiln_variant_code(pack, pass, variant, stages[s], KILN_TARGET_SPIRV, &code[s], &error) != KILN_OK || !code[s].size)
      die("no SPIR-V for stage %d: %s", s, error.message);

  /* 2. A device on Mesa's lavapipe (a CPU implementation: runs anywhere, no window). */
  VkApplicationInfo app = {VK_STRUCTURE_TYPE_APPLICATION_INFO, NULL, "vulkan_triangle", 1, NULL, 0, VK_API_VERSION_1_1};
  VkInstanceCreateInfo instance_info = {VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO, NULL, 0, &app, 0, NULL, 0, NULL};
  VkInstance instance;
  VK(vkCreateInstance(&instance_info, NULL, &instance));
  VkPhysicalDevice gpus[8], gpu = VK_NULL_HANDLE;
  uint32_t gpu_count = 8;
  VK(vkEnumeratePhysicalDevices(instance, &gpu_count, gpus));
  for (uint32_t i = 0; i < gpu_count && !gpu; ++i) {
    VkPhysicalDeviceProperties properties;
    vkGetPhysicalDeviceProperties(gpus[i], &properties);
    if (properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU) gpu = gpus[i];
  }
  if (!gpu) die("no CPU Vulkan device (Debian: mesa-vulkan-drivers)");
  float priority = 1.0f;
  VkDeviceQueueCreateInfo queue_info = {VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO, NULL, 0, 0, 1, &priority};
  VkDeviceCreateInfo device_info = {VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO, NULL, 0, 1, &queue_info, 0, NULL, 0, NULL, NULL};
  VkDevice device;
  VkQueue queue;
  VK(vkCreateDevice(gpu, &device_info, NULL, &device)); /* lavapipe's queue family 0 does graphics */
  vkGetDeviceQueue(device, 0, 0, &queue);

  /* 3. The colour target and what the frame is copied to. */
  VkImageCreateInfo image_info = {VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO, NULL, 0, VK_IMAGE_TYPE_2D, VK_FORMAT_R8G8B8A8_UNORM,
                                  {kWidth, kHeight, 1}, 1, 1, VK_SAMPLE_COUNT_1_BIT, VK_IMAGE_TILING_OPTIMAL,
                                  VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                                  VK_SHARING_MODE_EXCLUSIVE, 0, NULL, VK_IMAGE_LAYOUT_UNDEFINED};
  VkImage image;
  VkDeviceMemory image_memory;
  VkMemoryRequirements needs;
  VK(vkCreateImage(device, &image_info, NULL, &image));
  vkGetImageMemoryRequirements(device, image, &needs);
  VkMemoryAllocateInfo image_allocate = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, NULL, needs.size,
                                         memory_type(gpu, needs.memoryTypeBits, 0)};
  VK(vkAllocateMemory(device, &image_allocate, NULL, &image_memory));
  VK(vkBindImageMemory(device, image, image_memory, 0));
  VkImageViewCreateInfo view_info = {VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO, NULL, 0, image, VK_IMAGE_VIEW_TYPE_2D,
                                     VK_FORMAT_R8G8B8A8_UNORM, {0, 0, 0, 0}, {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1}};
  VkImageView view;
  VK(vkCreateImageView(device, &view_info, NULL, &view));
  VkDeviceMemory readback_memory;
  void* pixels;
  VkBuffer readback = make_buffer(device, gpu, kWidth * kHeight * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT, &readback_memory, &pixels);

  VkAttachmentDescription attachment = {0, VK_FORMAT_R8G8B8A8_UNORM, VK_SAMPLE_COUNT_1_BIT, VK_ATTACHMENT_LOAD_OP_CLEAR,
                                        VK_ATTACHMENT_STORE_OP_STORE, VK_ATTACHMENT_LOAD_OP_DONT_CARE,
                                        VK_ATTACHMENT_STORE_OP_DONT_CARE, VK_IMAGE_LAYOUT_UNDEFINED,
                                        VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL};
  VkAttachmentReference color_ref = {0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  VkSubpassDescription subpass = {0, VK_PIPELINE_BIND_POINT_GRAPHICS, 0, NULL, 1, &color_ref, NULL, NULL, 0, NULL};
  VkRenderPassCreateInfo pass_info = {VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO, NULL, 0, 1, &attachment, 1, &subpass, 0, NULL};
  VkRenderPass render_pass;
  VK(vkCreateRenderPass(device, &pass_info, NULL, &render_pass));
  VkFramebufferCreateInfo framebuffer_info = {VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO, NULL, 0, render_pass, 1, &view,
                                              kWidth, kHeight, 1};
  VkFramebuffer framebuffer;
  VK(vkCreateFramebuffer(device, &framebuffer_info, NULL, &framebuffer));

  /* 4. The descriptor set layout from the reflection: each stage's resources, one binding per (set 0) slot, stage
   *    flags OR-ed where both stages use it. This shader has one constant buffer, which gets the uniforms below. */
  VkDescriptorSetLayoutBinding bindings[16];
  uint32_t binding_count = 0, uniform_binding = UINT32_MAX;
  VkDeviceSize uniform_size = 0;
  for (int s = 0; s < 2; ++s) {
    const kiln_reflection* reflection = kiln_variant_reflection(pack, pass, variant, stages[s]);
    kiln_resource r;
    for (uint32_t i = 0; kiln_reflection_resource(reflection, i, &r); ++i) {
      uint32_t b = 0;
      if (r.set != 0) die("%s: set %u (this example makes set 0 only)", r.name, r.set);
      while (b < binding_count && bindings[b].binding != r.binding) ++b;
      if (b == binding_count) {
        if (binding_count == 16) die("too many bindings");
        VkDescriptorSetLayoutBinding added = {r.binding, descriptor_type(r.kind), r.count, 0, NULL};
        bindings[binding_count++] = added;
      }
      bindings[b].stageFlags |= r.stage_flags; /* kiln's stage flags are Vulkan's */
      if (r.kind != KILN_RESOURCE_UNIFORM_BUFFER) die("%s: this example binds constant buffers only", r.name);
      uniform_binding = r.binding;
      uniform_size = r.size;
    }
  }
  VkDescriptorSetLayoutCreateInfo set_layout_info = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO, NULL, 0,
                                                     binding_count, bindings};
  VkDescriptorSetLayout set_layout;
  VK(vkCreateDescriptorSetLayout(device, &set_layout_info, NULL, &set_layout));
  VkPipelineLayoutCreateInfo layout_info = {VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO, NULL, 0, 1, &set_layout, 0, NULL};
  VkPipelineLayout layout;
  VK(vkCreatePipelineLayout(device, &layout_info, NULL, &layout));

  /* The uniforms (cbuffer Frame: Color, Offset), in a buffer of the size the reflection gives. */
  if (uniform_binding == UINT32_MAX || uniform_size < 32) die("the variant has no 32-byte constant buffer");
  VkDeviceMemory uniform_memory;
  float* uniforms;
  VkBuffer uniform = make_buffer(device, gpu, uniform_size, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, &uniform_memory,
                                 (void**)&uniforms);
  const float frame[8] = {1.0f, 0.5f, 0.0f, 1.0f, /* Color: orange */ 0.0f, 0.0f, 0.0f, 0.0f /* Offset */};
  memcpy(uniforms, frame, sizeof frame);
  VkDescriptorPoolSize pool_size = {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1};
  VkDescriptorPoolCreateInfo pool_info = {VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO, NULL, 0, 1, 1, &pool_size};
  VkDescriptorPool pool;
  VK(vkCreateDescriptorPool(device, &pool_info, NULL, &pool));
  VkDescriptorSetAllocateInfo set_info = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO, NULL, pool, 1, &set_layout};
  VkDescriptorSet set;
  VK(vkAllocateDescriptorSets(device, &set_info, &set));
  VkDescriptorBufferInfo buffer_info = {uniform, 0, uniform_size};
  VkWriteDescriptorSet write = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, NULL, set, uniform_binding, 0, 1,
                                VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, NULL, &buffer_info, NULL};
  vkUpdateDescriptorSets(device, 1, &write, 0, NULL);

  /* 5. The vertex input from the reflection: one tightly packed buffer, attributes in location order. */
  const kiln_reflection* vertex_reflection = kiln_variant_reflection(pack, pass, variant, KILN_STAGE_VERTEX);
  VkVertexInputAttributeDescription attributes[16];
  uint32_t attribute_count = 0, stride = 0;
  kiln_stage_variable input;
  while (attribute_count < 16 && kiln_reflection_input(vertex_reflection, attribute_count, &input)) {
    VkVertexInputAttributeDescription attribute = {input.location, 0, vertex_format(&input), stride};
    attributes[attribute_count++] = attribute;
    stride += 4 * input.components;
  }
  if (stride != 2 * sizeof(float)) die("the vertex shader does not take one float2 position");
  const float triangle[6] = {0.0f, -0.5f, 0.5f, 0.5f, -0.5f, 0.5f}; /* clip space, y down */
  VkDeviceMemory vertex_memory;
  void* vertex_data;
  VkBuffer vertices = make_buffer(device, gpu, sizeof triangle, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, &vertex_memory, &vertex_data);
  memcpy(vertex_data, triangle, sizeof triangle);

  /* 6. The pipeline: the pack's modules and entry points. */
  VkShaderModule modules[2] = {make_module(device, code[0]), make_module(device, code[1])};
  VkPipelineShaderStageCreateInfo shader_stages[2] = {
      {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, NULL, 0, VK_SHADER_STAGE_VERTEX_BIT, modules[0],
       kiln_variant_entry_point(pack, pass, variant, KILN_STAGE_VERTEX), NULL},
      {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, NULL, 0, VK_SHADER_STAGE_FRAGMENT_BIT, modules[1],
       kiln_variant_entry_point(pack, pass, variant, KILN_STAGE_FRAGMENT), NULL}};
  VkVertexInputBindingDescription vertex_binding = {0, stride, VK_VERTEX_INPUT_RATE_VERTEX};
  VkPipelineVertexInputStateCreateInfo vertex_input = {VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO, NULL, 0, 1,
                                                       &vertex_binding, attribute_count, attributes};
  VkPipelineInputAssemblyStateCreateInfo assembly = {VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO, NULL, 0,
                                                     VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST, VK_FALSE};
  VkViewport viewport = {0.0f, 0.0f, kWidth, kHeight, 0.0f, 1.0f};
  VkRect2D scissor = {{0, 0}, {kWidth, kHeight}};
  VkPipelineViewportStateCreateInfo viewport_state = {VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO, NULL, 0, 1,
                                                      &viewport, 1, &scissor};
  VkPipelineRasterizationStateCreateInfo raster = {VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO, NULL, 0,
                                                   VK_FALSE, VK_FALSE, VK_POLYGON_MODE_FILL, VK_CULL_MODE_NONE,
                                                   VK_FRONT_FACE_COUNTER_CLOCKWISE, VK_FALSE, 0, 0, 0, 1.0f};
  VkPipelineMultisampleStateCreateInfo multisample = {VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO, NULL, 0,
                                                      VK_SAMPLE_COUNT_1_BIT, VK_FALSE, 0, NULL, VK_FALSE, VK_FALSE};
  VkPipelineColorBlendAttachmentState blend_attachment = {VK_FALSE, 0, 0, 0, 0, 0, 0, 0xF};
  VkPipelineColorBlendStateCreateInfo blend = {VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO, NULL, 0, VK_FALSE,
                                               VK_LOGIC_OP_COPY, 1, &blend_attachment, {0, 0, 0, 0}};
  VkGraphicsPipelineCreateInfo pipeline_info = {VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO, NULL, 0, 2, shader_stages,
                                                &vertex_input, &assembly, NULL, &viewport_state, &raster, &multisample,
                                                NULL, &blend, NULL, layout, render_pass, 0, VK_NULL_HANDLE, -1};
  VkPipeline pipeline;
  VK(vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &pipeline_info, NULL, &pipeline));

  /* 7. One frame: clear to black, draw, copy to the readback buffer. */
  VkCommandPoolCreateInfo command_pool_info = {VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO, NULL, 0, 0};
  VkCommandPool command_pool;
  VK(vkCreateCommandPool(device, &command_pool_info, NULL, &command_pool));
  VkCommandBufferAllocateInfo command_info = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO, NULL, command_pool,
                                              VK_COMMAND_BUFFER_LEVEL_PRIMARY, 1};
  VkCommandBuffer commands;
  VK(vkAllocateCommandBuffers(device, &command_info, &commands));
  VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO, NULL,
                                    VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT, NULL};
  VK(vkBeginCommandBuffer(commands, &begin));
  VkClearValue black = {{{0.0f, 0.0f, 0.0f, 1.0f}}};
  VkRenderPassBeginInfo pass_begin = {VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO, NULL, render_pass, framebuffer, scissor, 1, &black};
  vkCmdBeginRenderPass(commands, &pass_begin, VK_SUBPASS_CONTENTS_INLINE);
  vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
  vkCmdBindDescriptorSets(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, 0, 1, &set, 0, NULL);
  VkDeviceSize zero = 0;
  vkCmdBindVertexBuffers(commands, 0, 1, &vertices, &zero);
  vkCmdDraw(commands, 3, 1, 0, 0);
  vkCmdEndRenderPass(commands); /* leaves the image in TRANSFER_SRC_OPTIMAL */
  VkBufferImageCopy region = {0, 0, 0, {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1}, {0, 0, 0}, {kWidth, kHeight, 1}};
  vkCmdCopyImageToBuffer(commands, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback, 1, &region);
  VK(vkEndCommandBuffer(commands));
  VkSubmitInfo submit = {VK_STRUCTURE_TYPE_SUBMIT_INFO, NULL, 0, NULL, NULL, 1, &commands, 0, NULL};
  VK(vkQueueSubmit(queue, 1, &submit, VK_NULL_HANDLE));
  VK(vkQueueWaitIdle(queue));

  /* 8. The PNG (libpng's simplified API). */
  png_image png;
  memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  png.width = kWidth;
  png.height = kHeight;
  png.format = PNG_FORMAT_RGBA;
  if (!png_image_write_to_file(&png, argv[2], 0, pixels, 0, NULL)) die("%s: %s", argv[2], png.message);
  printf("vulkan_triangle: drew variant %u of pass Main (", variant);
  for (uint32_t k = 0; k < kiln_variant_keyword_count(pack, pass, variant); ++k)
    printf("%s%s", k ? " " : "", kiln_variant_keyword(pack, pass, variant, k));
  printf(") to %s\n", argv[2]);

  vkDestroyCommandPool(device, command_pool, NULL);
  vkDestroyPipeline(device, pipeline, NULL);
  for (int s = 0; s < 2; ++s) vkDestroyShaderModule(device, modules[s], NULL);
  vkDestroyDescriptorPool(device, pool, NULL);
  vkDestroyPipelineLayout(device, layout, NULL);
  vkDestroyDescriptorSetLayout(device, set_layout, NULL);
  vkDestroyBuffer(device, vertices, NULL);
  vkDestroyBuffer(device, uniform, NULL);
  vkDestroyBuffer(device, readback, NULL);
  vkDestroyFramebuffer(device, framebuffer, NULL);
  vkDestroyRenderPass(device, render_pass, NULL);
  vkDestroyImageView(device, view, NULL);
  vkDestroyImage(device, image, NULL);
  VkDeviceMemory memories[4] = {vertex_memory, uniform_memory, readback_memory, image_memory};
  for (int m = 0; m < 4; ++m) vkFreeMemory(device, memories[m], NULL);
  vkDestroyDevice(device, NULL);
  vkDestroyInstance(instance, NULL);
  if (usage_log && kiln_pack_flush_usage(pack, &error) != KILN_OK) die("%s: %s", error.file, error.message);
  kiln_pack_close(pack);
  return 0;
}
