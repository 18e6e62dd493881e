// SPDX-License-Identifier: Apache-2.0
// GLSL 450: the GL translation (gl_translate.hpp) of the module with its 16-bit floats widened.
#include "common/target_environment.hpp"
#include "cross/gl_translate.hpp"
#include "cross/targets.hpp"

namespace kiln {
namespace {

constexpr GlslOptions kGlslOptions{kTargetEnvironment.glsl_version, false, kTargetEnvironment.gl_clip_space_fixup};

std::string translate_glsl(CrossModules& modules, Reflection& reflection) {
  return translate_to_glsl(modules.gl_spirv(), kGlslOptions, reflection.glsl.emplace());
}

void record_glsl_options(ManifestOptions& options) { record_gl_options(kGlslOptions, options); }

}  // namespace

extern const TargetBackend kGlslTarget{Target::Glsl, "GLSL 450", record_glsl_options, translate_glsl};

}  // namespace kiln
