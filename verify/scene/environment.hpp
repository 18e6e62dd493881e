// SPDX-License-Identifier: Apache-2.0
// The environment a scene is lit by: a prefiltered radiance cubemap (mip m holds the GGX-prefiltered
// radiance for perceptual roughness m / (mips - 1)) and L2 spherical-harmonics irradiance, both produced
// by the CPU reference (`kiln-reference environment`). KENV file: "KENV", u32 version 1, u32 base size,
// u32 mip count, 27 float32 SH coefficients (rgb of the 9 terms SampleSH9 reads: irradiance / pi), then
// per mip, per face (+X -X +Y -Y +Z -Z), size^2 float32 RGBA texels, top row first.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace kiln::render {

struct Environment {
  uint32_t size = 0;
  uint32_t mips = 0;
  std::array<std::array<float, 3>, 9> sh{};
  std::vector<std::vector<float>> levels;  // per mip: 6 * s * s * 4 floats
  uint32_t level_size(uint32_t mip) const { return std::max(1u, size >> mip); }
};

Environment load_environment(const std::filesystem::path& path);
std::string encode_environment(const Environment& environment);

}  // namespace kiln::render
