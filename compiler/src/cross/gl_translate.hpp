// SPDX-License-Identifier: Apache-2.0
// The GL back ends' shared translation (glsl_target.cpp, gles_target.cpp): SPIRV-Cross's GLSL compiler with
// HLSL's separate textures and samplers combined for GL, and the binding records a GL renderer binds by.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "kiln/manifest_json.hpp"

namespace kiln {

struct GlslOptions {
  uint32_t version = 450;
  bool es = false;
  bool clip_space_fixup = true;  // remap depth from Vulkan's [0, 1] to GL's [-1, 1]
};

// `spirv`: the module with its 16-bit floats already widened for GL. Throws on failure.
std::string translate_to_glsl(const std::vector<uint32_t>& spirv, const GlslOptions& options, GlBindings& records);

// What a GL back end records in the manifest: its dialect's version and the clip-space fixup.
void record_gl_options(const GlslOptions& gl, ManifestOptions& options);

}  // namespace kiln
