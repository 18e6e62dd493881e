// SPDX-License-Identifier: Apache-2.0
// Part of stage 6: explicit 16-bit floats for the GL targets.
//
// SPIRV-Cross maps SPIR-V's 16-bit floats to GL_AMD_gpu_shader_half_float or GL_NV_gpu_shader5; a GL driver
// with neither (Mesa llvmpipe, most GLES drivers) rejects the shader. GLSL's way to say "16 bits are enough"
// is precision: mediump. So before cross-compiling to GLSL 450 and GLSL ES, kiln widens every 16-bit float
// of a module to 32 bits and decorates the widened values RelaxedPrecision, which SPIRV-Cross emits as
// mediump in GLSL ES (and which GLSL 450 ignores). Vulkan (SPIR-V) and Metal keep the true 16-bit types.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "kiln/result.hpp"

namespace kiln {

struct Widened {
  bool changed = false;     // false: the module had no 16-bit floats, or only ones that cannot be widened
  std::string unchanged_because;
  std::vector<uint32_t> spirv;
};

// Leaves modules with 16-bit storage (buffers, push constants, stage interfaces of 16-bit type) unchanged:
// widening would change their memory layout or interface. Fails on what is not a SPIR-V module, or when
// SPIRV-Tools cannot merge the widened types.
Result<Widened> widen_float16_for_gl(const std::vector<uint32_t>& spirv);

}  // namespace kiln
