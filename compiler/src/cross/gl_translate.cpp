// SPDX-License-Identifier: Apache-2.0
#include "cross/gl_translate.hpp"

#include <spirv_cross/spirv_glsl.hpp>

#include <algorithm>

namespace kiln {

std::string translate_to_glsl(const std::vector<uint32_t>& spirv, const GlslOptions& gl, GlBindings& records) {
  spirv_cross::CompilerGLSL compiler(spirv);
  spirv_cross::CompilerGLSL::Options options;
  options.version = gl.version;
  options.es = gl.es;
  options.vulkan_semantics = false;      // plain OpenGL: no descriptor sets, combined samplers
  options.enable_420pack_extension = !gl.es;
  options.fragment.default_float_precision = spirv_cross::CompilerGLSL::Options::Highp;
  options.fragment.default_int_precision = spirv_cross::CompilerGLSL::Options::Highp;
  // GL clip space has z in [-1, 1]; shaders are written for Vulkan's [0, 1].
  options.vertex.fixup_clipspace = gl.clip_space_fixup;
  compiler.set_common_options(options);

  // HLSL keeps textures and samplers apart; GL needs them combined, each bound at its texture's binding.
  // Texel fetches and size queries (HLSL Load, GetDimensions) use no sampler: SPIRV-Cross pairs them with a
  // dummy one, named here so that the combined sampler's name says what it is.
  if (uint32_t dummy = compiler.build_dummy_sampler_for_combined_images(); dummy != 0)
    compiler.set_name(dummy, "kiln_no_sampler");
  compiler.build_combined_image_samplers();
  for (const spirv_cross::CombinedImageSampler& pair : compiler.get_combined_image_samplers()) {
    const std::string texture = compiler.get_name(pair.image_id);
    const std::string sampler = compiler.get_name(pair.sampler_id);
    const uint32_t binding = compiler.get_decoration(pair.image_id, spv::DecorationBinding);
    const std::string name = texture + "_" + sampler;
    compiler.set_name(pair.combined_id, name);
    compiler.set_decoration(pair.combined_id, spv::DecorationBinding, binding);
    records.combined_image_samplers.push_back({name, texture, sampler, binding});
  }
  std::string source = compiler.compile();
  spirv_cross::ShaderResources resources = compiler.get_shader_resources();
  // An input attachment (SubpassInput) is a sampler uniform of its own name in GL, read with texelFetch at
  // gl_FragCoord: the attachment's texture goes to its binding, with no sampler.
  for (const auto& input : resources.subpass_inputs) {
    const std::string name = compiler.get_name(input.id);
    records.combined_image_samplers.push_back({name, name, "", compiler.get_decoration(input.id, spv::DecorationBinding)});
  }
  std::sort(records.combined_image_samplers.begin(), records.combined_image_samplers.end(),
            [](const GlCombinedSampler& a, const GlCombinedSampler& b) { return a.name < b.name; });
  // Blocks by their interface name (what GL's glGetUniformBlockIndex takes), not the unnamed HLSL instance.
  for (const auto& buffer : resources.uniform_buffers)
    records.blocks.push_back({buffer.name, ResourceKind::UniformBuffer, compiler.get_decoration(buffer.id, spv::DecorationBinding)});
  for (const auto& buffer : resources.storage_buffers)
    records.blocks.push_back({buffer.name, ResourceKind::StorageBuffer, compiler.get_decoration(buffer.id, spv::DecorationBinding)});
  return source;
}

void record_gl_options(const GlslOptions& gl, ManifestOptions& options) {
  (gl.es ? options.gles_version : options.glsl_version) = gl.version;
  options.gl_clip_space_fixup = gl.clip_space_fixup;
}

}  // namespace kiln
