#include "golden/scene_inputs.hpp"

#include "reference/rasterize.hpp"

#include <fstream>
#include <sstream>
#include <stdexcept>

namespace kiln::reference {

SceneInputs::SceneInputs(render::SceneRenderer& renderer)
    : renderer_(renderer),
      // The reference's own geometry, not lavapipe's (golden.Scenes/ReferenceGeometry.* checks that they agree).
      gbuffer_(rasterize_gbuffer(renderer.scene(), renderer.frame(1).view_projection, renderer.width(), renderer.height())),
      environment_(render::load_environment(renderer.scene().environment)),
      additional_(renderer.additional_shadow_atlas()) {
  std::ifstream in(renderer.scene().dfg, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + renderer.scene().dfg.string());
  std::stringstream bytes;
  bytes << in.rdbuf();
  dfg_ = decode_dfg_table(bytes.str());
  prepare({});
}

void SceneInputs::prepare(const std::vector<std::string>& keywords) {
  const int cascades = render::cascades_for(keywords, renderer_.scene());
  if (main_shadows_.count(cascades)) return;
  main_shadows_[cascades] = renderer_.main_shadow_atlas(cascades);
  frames_[cascades] = &renderer_.frame(cascades);
}

ReferenceInputs SceneInputs::inputs(const std::vector<std::string>& keywords) const {
  const int cascades = render::cascades_for(keywords, renderer_.scene());
  ReferenceInputs in;
  in.scene = &renderer_.scene();
  in.environment = &environment_;
  in.dfg = &dfg_;
  in.gbuffer = &gbuffer_;
  in.frame = frames_.at(cascades);
  in.main_shadow = &main_shadows_.at(cascades);
  in.additional_shadow = &additional_;
  in.additional_frame = frames_.at(1);
  return in;
}

}  // namespace kiln::reference
