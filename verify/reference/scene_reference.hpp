// SPDX-License-Identifier: Apache-2.0
// The CPU reference for whole images: shades the pixels of a G-buffer (geometry as the renderer rasterized
// it) in double precision with the shader library's physics re-implemented from reference.hpp, for the
// shading model a variant's keywords select. It shares no shading code with shaderlib/: only input data
// (the scene, the G-buffer, the shadow-map depths, the environment and the DFG table).
//
// Also generates the environment the scenes are lit by: a procedural sky, prefiltered for GGX into a cube
// mip chain (split-sum, Karis 2013) and projected onto L2 spherical harmonics (Ramamoorthi-Hanrahan 2001).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "reference/reference.hpp"
#include "scene/environment.hpp"
#include "scene/frame_images.hpp"
#include "scene/scene.hpp"

namespace kiln::reference {

// The procedural sky's radiance (linear RGB) in direction `d` (unit).
std::array<double, 3> SkyRadiance(const Vec3& d);
// Prefiltered cube of `size` texels per side with `mips` levels, `samples` GGX samples per texel, and SH9.
render::Environment make_environment(uint32_t size, uint32_t mips, uint32_t samples);

// What the reference needs beyond the G-buffer: the frame data and the shadow maps as rendered.
struct ReferenceInputs {
  const render::Scene* scene = nullptr;
  const render::Environment* environment = nullptr;
  const DfgTable* dfg = nullptr;
  const render::GBuffer* gbuffer = nullptr;
  const render::FrameSetup* frame = nullptr;        // for the variant's cascade count
  const render::ShadowAtlas* main_shadow = nullptr;  // same
  const render::ShadowAtlas* additional_shadow = nullptr;
  const render::FrameSetup* additional_frame = nullptr;  // shadow views of the additional lights
  // > 0: the image-based lighting is integrated from the sky itself (SkyRadiance) with this many GGX-importance
  // samples per pixel (and a quarter as many cosine samples for the diffuse part), and the specular albedo and
  // energy compensation come from the same samples: no SH9, no prefiltered cube and no DFG table, i.e. nothing
  // the shader samples. Isotropic, non-mobile, non-EnvBRDFApprox models only (others shade as with 0).
  uint32_t integrate_environment_samples = 0;
  uint32_t sample_salt = 0;  // decorrelates two integrations of one image (a noise estimate)
};

// Shades every covered pixel for the variant `keywords` of the Forward pass; background pixels are 0.
// Alpha: 1 covered, 0 background, render::kUnstablePixel where a shadow test sits on a texel or depth tie.
render::Image shade_image(const ReferenceInputs& inputs, const std::vector<std::string>& keywords);

// The keywords that change the reference image (the Forward+ list must not change it: same lights).
std::vector<std::string> reference_key(const std::vector<std::string>& keywords);

}  // namespace kiln::reference
