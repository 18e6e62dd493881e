// SPDX-License-Identifier: Apache-2.0
// The reference's own geometry: the scene's meshes transformed and rasterized on the CPU in double precision, so
// that the reference's G-buffer and shadow maps are not the renderer's (docs/golden.md, "A reference that shares nothing it judges").
// The rules are Vulkan's for the renderer's pipelines: pixel centres at half-integers, no culling, depth test LESS,
// perspective-correct interpolation, the GBuffer pass's vertex expressions (world position, normal through the
// inverse transpose, normalized per vertex; tangent through the object transform).
#pragma once

#include <cstdint>
#include <vector>

#include "scene/frame_images.hpp"
#include "scene/scene.hpp"

namespace kiln::reference {

// Half the side of the square around each pixel centre within which a change of the visible object makes the
// pixel a coverage tie: a GPU snaps vertices to 1/256 pixel (lavapipe: 8 sub-pixel bits) and tests fp32 depths, so
// within about that distance of a silhouette or an intersection it may pick the other surface.
inline constexpr double kCoverageTiePixels = 1.0 / 128;

// A G-buffer in the renderer's format (scene/frame_images.hpp). position.w: 1 covered, 0 background,
// render::kUnstablePixel where the visible object changes within kCoverageTiePixels of the pixel centre.
render::GBuffer rasterize_gbuffer(const render::Scene& scene, const render::Mat4& view_projection, uint32_t width,
                                  uint32_t height);

// A shadow-depth atlas as the ShadowCaster pass draws it: every view's rectangle, the casters moved by the
// caster-side depth and normal bias (towards the light's position for punctual views), window depth, cleared to 1.
// `tie` marks texels whose nearest caster changes within kCoverageTiePixels of the texel centre, and
// `depth_tolerance` how far the depth moves within that distance elsewhere.
render::ShadowAtlas rasterize_shadow_atlas(const render::Scene& scene, const std::vector<render::ShadowView>& views,
                                           uint32_t width, uint32_t height, const render::ShadowDesc& bias);

}  // namespace kiln::reference
