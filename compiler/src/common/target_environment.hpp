// SPDX-License-Identifier: Apache-2.0
// What every kiln output targets, stated once: the front end's SPIR-V target, the validator's and optimizer's
// environment, the cross-compilers' language versions, and what the manifest records of them.
#pragma once

namespace kiln {

struct TargetEnvironment {
  // Vulkan 1.1 / SPIR-V 1.3: what every Vulkan 1.1 driver (lavapipe included) takes.
  int vulkan_major = 1, vulkan_minor = 1;
  int spirv_major = 1, spirv_minor = 3;
  const char* spirv_env = "vulkan1.1";  // spirv-val --target-env, and the manifest
  int glsl_version = 450;               // GLSL 4.50 core
  int gles_version = 310;               // GLSL ES 3.10
  int msl_major = 2, msl_minor = 1;     // MSL 2.1 (macOS)
  const char* msl_version = "2.1";
  bool gl_clip_space_fixup = true;      // GL outputs remap depth from Vulkan's [0, 1] to GL's [-1, 1]
};

inline constexpr TargetEnvironment kTargetEnvironment{};

}  // namespace kiln
