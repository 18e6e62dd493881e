// SPDX-License-Identifier: Apache-2.0
// Renders a scene with a pack's Forward pass on lavapipe: shadow maps by the pack's ShadowCaster pass (a
// directional map or a 2x2 cascade atlas, and an atlas for shadowed point/spot lights), the Forward pass per
// object, readback of the float image the fragment shader wrote. Resources are bound by the names and
// binding numbers the pack's reflection records (never hard-coded), and constant buffers are filled at the
// member offsets it records. Pipelines and scene resources are made once and reused across variants.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "coverage/coverage_recorder.hpp"
#include "kiln/pack_reader.hpp"
#include "scene/environment.hpp"
#include "scene/frame_images.hpp"
#include "scene/image.hpp"
#include "scene/scene.hpp"
#include "render/vulkan_context.hpp"

namespace kiln::render {

class SceneRenderer {
 public:
  // `width`/`height` 0: the scene's size. Throws a VerifyError on a pack or scene the renderer cannot
  // use (a missing pass, a resource name it does not provide, a light list that overflows a tile).
  SceneRenderer(VulkanContext& context, const PackReader& pack, const Scene& scene, uint32_t width = 0,
                uint32_t height = 0);
  ~SceneRenderer();
  SceneRenderer(const SceneRenderer&) = delete;
  SceneRenderer& operator=(const SceneRenderer&) = delete;

  // The Forward pass variant for `keywords` (PackReader::select rules), or a selected variant of any pass that
  // draws an image (Forward, and passes that read only the frame, material and object constants: DepthOnly,
  // DepthNormals).
  Image render(const std::vector<std::string>& keywords);
  Image render(const SelectedVariant& variant);
  // Milliseconds of the last render: pipeline creation and draw (submit to idle).
  double last_pipeline_ms() const { return last_pipeline_ms_; }
  double last_draw_ms() const { return last_draw_ms_; }
  // Image pipelines compiled, and renders that reused one (byte-identical modules of an earlier variant).
  size_t pipelines_created() const { return pipelines_created_; }
  size_t pipelines_reused() const { return pipelines_reused_; }

  // From now on, each draw's coverage (a --coverage pack's) goes to `recorder` (nullptr: nowhere).
  void record_coverage(CoverageRecorder* recorder);

  GBuffer render_gbuffer(const PackReader& debug_pack);
  // The shadow maps a variant with `cascades` (1 or the scene's count) reads, and the additional-light atlas.
  ShadowAtlas main_shadow_atlas(int cascades);
  ShadowAtlas additional_shadow_atlas();
  const FrameSetup& frame(int cascades);
  const Scene& scene() const { return scene_; }
  uint32_t width() const { return width_; }
  uint32_t height() const { return height_; }

 private:
  struct State;
  std::unique_ptr<State> state_;
  Scene scene_;  // with the image size overridden
  uint32_t width_, height_;
  double last_pipeline_ms_ = 0, last_draw_ms_ = 0;
  size_t pipelines_created_ = 0, pipelines_reused_ = 0;
  VkPipeline image_pipeline(const SelectedVariant& variant, VkPipelineLayout layout);
};


}  // namespace kiln::render
