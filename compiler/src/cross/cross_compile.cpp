#include "common/target_environment.hpp"
#include "cross/cross_compile.hpp"

#include "cross/widen_float16.hpp"
#include "optimize/spirv_tools.hpp"

#include <spirv_cross/spirv_glsl.hpp>
#include <spirv_cross/spirv_msl.hpp>

#include <map>

#include <spirv_cross/spirv_cross_c.h>

#include "spirv_cross_fingerprint.hpp"  // generated: KILN_SPIRV_CROSS_LIBRARIES_SHA256

namespace kiln {
namespace {

// `spirv`: the module with its 16-bit floats already widened for GL.
CrossResult to_glsl(const std::vector<uint32_t>& spirv, bool es) {
  CrossResult result;
  spirv_cross::CompilerGLSL compiler(spirv);
  spirv_cross::CompilerGLSL::Options options;
  options.version = static_cast<uint32_t>(es ? kTargetEnvironment.gles_version : kTargetEnvironment.glsl_version);
  options.es = es;
  options.vulkan_semantics = false;      // plain OpenGL: no descriptor sets, combined samplers
  options.enable_420pack_extension = !es;
  options.fragment.default_float_precision = spirv_cross::CompilerGLSL::Options::Highp;
  options.fragment.default_int_precision = spirv_cross::CompilerGLSL::Options::Highp;
  // GL clip space has z in [-1, 1]; shaders are written for Vulkan's [0, 1].
  options.vertex.fixup_clipspace = kTargetEnvironment.gl_clip_space_fixup;
  compiler.set_common_options(options);

  // HLSL keeps textures and samplers apart; GL needs them combined, each bound at its texture's binding.
  // Texel fetches and size queries (HLSL Load, GetDimensions) use no sampler: SPIRV-Cross pairs them with a
  // dummy one, named here so that the combined sampler's name says what it is.
  if (uint32_t dummy = compiler.build_dummy_sampler_for_combined_images(); dummy != 0)
    compiler.set_name(dummy, "kiln_no_sampler");
  compiler.build_combined_image_samplers();
  GlBindings& records = result.gl.emplace();
  for (const spirv_cross::CombinedImageSampler& pair : compiler.get_combined_image_samplers()) {
    const std::string texture = compiler.get_name(pair.image_id);
    const std::string sampler = compiler.get_name(pair.sampler_id);
    const uint32_t binding = compiler.get_decoration(pair.image_id, spv::DecorationBinding);
    const std::string name = texture + "_" + sampler;
    compiler.set_name(pair.combined_id, name);
    compiler.set_decoration(pair.combined_id, spv::DecorationBinding, binding);
    records.combined_image_samplers.push_back({name, texture, sampler, binding});
  }
  result.source = compiler.compile();
  std::sort(records.combined_image_samplers.begin(), records.combined_image_samplers.end(),
            [](const GlCombinedSampler& a, const GlCombinedSampler& b) { return a.name < b.name; });
  spirv_cross::ShaderResources resources = compiler.get_shader_resources();
  // Blocks by their interface name (what GL's glGetUniformBlockIndex takes), not the unnamed HLSL instance.
  for (const auto& buffer : resources.uniform_buffers)
    records.blocks.push_back({buffer.name, ResourceKind::UniformBuffer, compiler.get_decoration(buffer.id, spv::DecorationBinding)});
  for (const auto& buffer : resources.storage_buffers)
    records.blocks.push_back({buffer.name, ResourceKind::StorageBuffer, compiler.get_decoration(buffer.id, spv::DecorationBinding)});
  result.ok = true;
  return result;
}

CrossResult to_msl(const std::vector<uint32_t>& spirv) {
  CrossResult result;
  spirv_cross::CompilerMSL compiler(spirv);
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
                           &resources.separate_samplers, &resources.sampled_images})
    for (const auto& resource : *list) declared[resource.id] = resource.name;
  result.source = compiler.compile();
  std::vector<MslResource>& indices = result.msl.emplace().resources;
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
  std::sort(indices.begin(), indices.end(), [](const MslResource& a, const MslResource& b) { return a.name < b.name; });
  result.ok = true;
  return result;
}

}  // namespace

CrossResult CrossCompiler::compile(Target target) {
  if ((target == Target::Glsl || target == Target::Gles) && !gl_ready_) {
    gl_ready_ = true;
    // Explicit 16-bit floats become mediump 32-bit floats for GL (see widen_float16.hpp).
    WidenResult widened = widen_float16_for_gl(spirv_);
    if (!widened.ok) {
      gl_error_ = "widening 16-bit floats for GL: " + widened.reason;
    } else if (widened.changed) {
      SpirvStepResult valid = validate_spirv(widened.spirv);
      if (!valid.ok) {
        gl_error_ = "widening 16-bit floats for GL produced invalid SPIR-V:";
        for (const auto& m : valid.messages) gl_error_ += " " + m;
      }
    }
    gl_spirv_ = std::move(widened.spirv);
  }
  try {
    switch (target) {
      case Target::Glsl:
      case Target::Gles:
        if (!gl_error_.empty()) return CrossResult{false, gl_error_, {}, {}};
        return to_glsl(gl_spirv_, target == Target::Gles);
      case Target::Msl: return to_msl(spirv_);
      case Target::Spirv: break;
    }
    return CrossResult{false, "SPIR-V is not a cross-compilation target", {}, {}};
  } catch (const std::exception& error) {
    return CrossResult{false, error.what(), {}, {}};
  }
}

std::string spirv_cross_version() {
  return "C API " + std::to_string(SPVC_C_API_VERSION_MAJOR) + "." + std::to_string(SPVC_C_API_VERSION_MINOR) + "." +
         std::to_string(SPVC_C_API_VERSION_PATCH) + ", libraries sha256 " +
         std::string(KILN_SPIRV_CROSS_LIBRARIES_SHA256).substr(0, 16);
}

}  // namespace kiln
