// SPDX-License-Identifier: Apache-2.0
// MSL 2.1 for macOS, with the [[buffer]], [[texture]] and [[sampler]] index of each resource recorded.
#include "common/target_environment.hpp"
#include "cross/targets.hpp"

#include <spirv_cross/spirv_msl.hpp>

#include <algorithm>
#include <map>
#include <stdexcept>

namespace kiln {
namespace {

std::string translate_msl(CrossModules& modules, Reflection& reflection) {
  spirv_cross::CompilerMSL compiler(modules.spirv());
  // Metal has no geometry stage (SPIRV-Cross writes a function of type "unknown"), and its tessellation runs the
  // hull shader as a compute kernel with SPIRV-Cross's own buffer conventions, which no renderer here follows.
  switch (compiler.get_execution_model()) {
    case spv::ExecutionModelGeometry: throw std::runtime_error("Metal has no geometry shader stage");
    case spv::ExecutionModelTessellationControl:
    case spv::ExecutionModelTessellationEvaluation:
      throw std::runtime_error("Metal tessellation (a hull shader as a compute kernel) is not written by kiln");
    default: break;
  }
  spirv_cross::CompilerMSL::Options options;
  options.platform = spirv_cross::CompilerMSL::Options::macOS;
  options.set_msl_version(kTargetEnvironment.msl_major, kTargetEnvironment.msl_minor);
  compiler.set_msl_options(options);
  // Names as the HLSL declares them (and as the SPIR-V reflection and the GL records name them), taken before
  // compile(): SPIRV-Cross renames a StructuredBuffer's variable that collides with its block's name
  // ("_AdditionalLights" becomes "_AdditionalLights_1" in the MSL), and a user binds by the declared name.
  // For an HLSL cbuffer (an unnamed block instance) the name is the block's, e.g. "PerFrame".
  spirv_cross::ShaderResources resources = compiler.get_shader_resources();
  std::map<uint32_t, std::string> declared;
  for (const auto* list : {&resources.uniform_buffers, &resources.storage_buffers, &resources.separate_images,
                           &resources.separate_samplers, &resources.sampled_images, &resources.storage_images,
                           &resources.subpass_inputs})
    for (const auto& resource : *list) {
      declared[resource.id] = resource.name;
      // SPIRV-Cross 2023 asserts (aborts) on a runtime array without argument buffers, which kiln's MSL does not use.
      const spirv_cross::SPIRType& type = compiler.get_type(resource.type_id);
      if (!type.array.empty() && type.array_size_literal.back() && type.array.back() == 0)
        throw std::runtime_error("'" + resource.name + "' is an unbounded resource array, which Metal binds only through "
                                 "argument buffers; kiln's MSL target binds each resource at its own index");
    }
  std::string source = compiler.compile();
  std::vector<MslResource>& indices = reflection.msl.emplace().resources;
  auto record = [&](const spirv_cross::SmallVector<spirv_cross::Resource>& list, MslResourceKind kind) {
    for (const auto& resource : list) {
      uint32_t index = compiler.get_automatic_msl_resource_binding(resource.id);
      if (index == uint32_t(-1)) continue;  // not used by the entry point
      indices.push_back({declared.at(resource.id), kind, index});
    }
  };
  record(resources.uniform_buffers, MslResourceKind::Buffer);
  record(resources.storage_buffers, MslResourceKind::Buffer);
  record(resources.separate_images, MslResourceKind::Texture);
  record(resources.separate_samplers, MslResourceKind::Sampler);
  record(resources.sampled_images, MslResourceKind::Texture);
  // RWTexture and RWBuffer are textures with write access in Metal; an input attachment is a texture read at the
  // fragment's position (SPIRV-Cross's default for macOS, which has no framebuffer fetch).
  record(resources.storage_images, MslResourceKind::Texture);
  record(resources.subpass_inputs, MslResourceKind::Texture);
  std::sort(indices.begin(), indices.end(), [](const MslResource& a, const MslResource& b) { return a.name < b.name; });
  return source;
}

void record_msl_options(ManifestOptions& options) { options.msl_version = kTargetEnvironment.msl_version; }

}  // namespace

extern const TargetBackend kMslTarget{Target::Msl, "MSL 2.1 (macOS)", record_msl_options, translate_msl};

}  // namespace kiln
