// SPDX-License-Identifier: Apache-2.0
#include "reference/scene_inputs.hpp"
#include "scene/verify_error.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "reference/rasterize.hpp"

namespace kiln::reference {

SceneInputs::SceneInputs(render::Scene scene)
    : scene_(std::move(scene)),
      gbuffer_(rasterize_gbuffer(scene_, frame(1).view_projection, scene_.width, scene_.height)),
      environment_(render::load_environment(scene_.environment)) {
  const render::FrameSetup& base = frame(1);
  additional_ = rasterize_shadow_atlas(scene_, base.additional_views, std::max(1u, base.additional_atlas_width),
                                       std::max(1u, base.additional_atlas_height), scene_.additional_shadow);
  std::ifstream in(scene_.dfg, std::ios::binary);
  if (!in) render::fail(DiagId::GoldenData, scene_.dfg, "cannot open the DFG table");
  std::stringstream bytes;
  bytes << in.rdbuf();
  dfg_ = decode_dfg_table(bytes.str());
  prepare({});
}

const render::FrameSetup& SceneInputs::frame(int cascades) {
  auto found = frames_.find(cascades);
  if (found == frames_.end()) found = frames_.emplace(cascades, render::setup_frame(scene_, cascades)).first;
  return found->second;
}

void SceneInputs::prepare(const std::vector<std::string>& keywords) {
  const int cascades = render::cascades_for(keywords, scene_);
  if (main_shadows_.count(cascades)) return;
  const render::FrameSetup& f = frame(cascades);
  main_shadows_[cascades] = rasterize_shadow_atlas(scene_, f.main_views, f.main_atlas_size, f.main_atlas_size,
                                                   scene_.main_shadow);
}

ReferenceInputs SceneInputs::inputs(const std::vector<std::string>& keywords) const {
  const int cascades = render::cascades_for(keywords, scene_);
  ReferenceInputs in;
  in.scene = &scene_;
  in.environment = &environment_;
  in.dfg = &dfg_;
  in.gbuffer = &gbuffer_;
  in.frame = &frames_.at(cascades);
  in.main_shadow = &main_shadows_.at(cascades);
  in.additional_shadow = &additional_;
  in.additional_frame = &frames_.at(1);
  return in;
}

}  // namespace kiln::reference
