// SPDX-License-Identifier: Apache-2.0
// Renders a scene with a pack's GLSL 450 or GLSL ES outputs on a real OpenGL driver (Mesa llvmpipe through
// EGL surfaceless, see gl_context.hpp): the same scene, the same bytes (scene_data.hpp) and the same draws as
// the Vulkan renderer, shadow maps drawn by the ShadowCaster pass's GL output. Every buffer, texture and
// sampler is bound where the manifest's GL records say (blocks and combined image samplers per stage), and
// those records are checked against what the driver reports for the linked program.
//
// Conventions, so that the GL image matches the Vulkan one texel for texel: kiln's GLSL is cross-compiled with
// SPIRV-Cross's clip-space fixup (z' = 2z - w), so GL's default depth range gives the Vulkan window depth; the
// image is read back bottom row first, which puts Vulkan's NDC y = -1 (top) in row 0 in both APIs, and
// gl_FragCoord.y then equals Vulkan's FragCoord.y (Forward+ tiles agree); the face-orientation rule of GL has
// the opposite sign to Vulkan's for the same window coordinates, so the front face is GL_CW here.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "kiln/pack_reader.hpp"
#include "render/gl_context.hpp"
#include "coverage/coverage_recorder.hpp"
#include "scene/image.hpp"
#include "scene/scene.hpp"

namespace kiln::render {

class GlSceneRenderer {
 public:
  // `width`/`height` 0: the scene's size. Throws a VerifyError on a pack, scene or driver the renderer
  // cannot use (a missing pass or GLSL target, a resource it does not provide, a missing GL feature).
  GlSceneRenderer(GlContext& gl, const PackReader& pack, const Scene& scene, uint32_t width = 0, uint32_t height = 0);
  ~GlSceneRenderer();
  GlSceneRenderer(const GlSceneRenderer&) = delete;
  GlSceneRenderer& operator=(const GlSceneRenderer&) = delete;

  // The Forward pass variant for `keywords` (PackReader::select rules), or a selected variant of any pass that
  // draws an image (as SceneRenderer::render); drawn with its GLSL 450 output on a desktop context and its GLSL
  // ES output on an ES context.
  Image render(const std::vector<std::string>& keywords);
  Image render(const SelectedVariant& variant);
  // Image programs compiled and linked, and renders that reused one (byte-identical GLSL of an earlier variant).
  size_t pipelines_created() const;
  size_t pipelines_reused() const;
  // From now on, each draw's coverage (a --coverage pack's) goes to `recorder` (nullptr: nowhere).
  void record_coverage(CoverageRecorder* recorder);
  uint32_t width() const { return width_; }
  uint32_t height() const { return height_; }

 private:
  struct State;
  std::unique_ptr<State> state_;
  Scene scene_;
  uint32_t width_, height_;
};

}  // namespace kiln::render
