// SPDX-License-Identifier: Apache-2.0
// The images a scene's inputs come as: the G-buffer the debug pack's GBuffer pass draws, and the shadow-map depth
// atlases. Plain data, shared by the renderer that makes them and the CPU reference that reads them.
#pragma once

#include <cstdint>
#include <vector>

#include "scene/image.hpp"

namespace kiln::render {

// What the debug pack's GBuffer pass wrote, per pixel (see shaderlib/passes/DebugGBuffer.hlsl).
struct GBuffer {
  Image position;   // xyz world position as interpolated, w 1 where covered, 0 for background
  Image normal;     // xyz interpolated (not renormalized) world normal, w +1 front face, -1 back face
  Image tangent;    // xyz interpolated world tangent, w bitangent sign
  Image material0;  // rgb base color, a metallic
  Image material1;  // x perceptual roughness, y reflectance, z anisotropy
};

// A depth atlas as the ShadowCaster pass rendered it (depth in [0, 1], row-major, top row first).
struct ShadowAtlas {
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<float> depth;
  // The reference's own atlases: 1 where the nearest caster is a coverage tie, and how far the depth moves within
  // the tie distance of the texel centre (a GPU's depth there may be anywhere in that range).
  std::vector<uint8_t> tie;
  std::vector<float> depth_tolerance;
};

}  // namespace kiln::render
