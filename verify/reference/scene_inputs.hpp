// SPDX-License-Identifier: Apache-2.0
// The CPU reference's inputs for one scene, all made from the scene itself: the G-buffer and the shadow atlases
// the reference rasterizes (reference/rasterize.hpp), the frames (camera, shadow views, tile lists) the scene
// defines, and the environment and DFG table it names. No renderer is involved: what lavapipe draws is compared with
// these (golden.Scenes/ReferenceGeometry.*), never used by them.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "reference/scene_reference.hpp"

namespace kiln::reference {

// Atlases for a variant's cascade layout are made by prepare(); inputs() is then safe to call from several threads.
class SceneInputs {
 public:
  explicit SceneInputs(render::Scene scene);  // at the size it is shaded at (scene.width x scene.height)
  void prepare(const std::vector<std::string>& keywords);  // the variant's cascade layout
  ReferenceInputs inputs(const std::vector<std::string>& keywords) const;
  const render::Scene& scene() const { return scene_; }
  const render::GBuffer& gbuffer() const { return gbuffer_; }
  const render::FrameSetup& frame(int cascades);

 private:
  render::Scene scene_;
  std::map<int, render::FrameSetup> frames_;
  render::GBuffer gbuffer_;
  render::Environment environment_;
  DfgTable dfg_;
  std::map<int, render::ShadowAtlas> main_shadows_;
  render::ShadowAtlas additional_;
};

}  // namespace kiln::reference
