// SPDX-License-Identifier: Apache-2.0
// GLSL ES 310: the GL translation (gl_translate.hpp) of the module with its 16-bit floats widened.
#include "common/target_environment.hpp"
#include "cross/gl_translate.hpp"
#include "cross/targets.hpp"

namespace kiln {
namespace {

constexpr GlslOptions kGlesOptions{kTargetEnvironment.gles_version, true, kTargetEnvironment.gl_clip_space_fixup};

std::string translate_gles(CrossModules& modules, Reflection& reflection) {
  return translate_to_glsl(modules.gl_spirv(), kGlesOptions, reflection.gles.emplace());
}

void record_gles_options(ManifestOptions& options) { record_gl_options(kGlesOptions, options); }

}  // namespace

extern const TargetBackend kGlesTarget{Target::Gles, "GLSL ES 310", record_gles_options, translate_gles};

}  // namespace kiln
