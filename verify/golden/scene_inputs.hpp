// The CPU reference's inputs for one scene, as the renderer makes them. The reference itself (reference/) links
// no renderer: it reads only this data.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "reference/scene_reference.hpp"
#include "render/renderer.hpp"

namespace kiln::reference {

// The inputs of one scene: the G-buffer the reference rasterizes itself (reference/rasterize.hpp), the shadow
// atlases and frames the renderer provides, and the environment and DFG table the scene names. Atlases and frames are made by
// prepare() on the renderer's thread; inputs() is then safe to call from several threads.
class SceneInputs {
 public:
  explicit SceneInputs(render::SceneRenderer& renderer);
  void prepare(const std::vector<std::string>& keywords);  // the variant's cascade layout
  ReferenceInputs inputs(const std::vector<std::string>& keywords) const;
  const render::GBuffer& gbuffer() const { return gbuffer_; }

 private:
  render::SceneRenderer& renderer_;
  render::GBuffer gbuffer_;
  render::Environment environment_;
  DfgTable dfg_;
  std::map<int, render::ShadowAtlas> main_shadows_;
  std::map<int, const render::FrameSetup*> frames_;
  render::ShadowAtlas additional_;
};

}  // namespace kiln::reference
