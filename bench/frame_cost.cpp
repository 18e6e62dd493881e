// SPDX-License-Identifier: Apache-2.0
// Additional lights inside rendered frames: what the plain per-pixel loop, Forward+ tile lists and per-vertex
// lighting cost and how far each is from the CPU reference, in the stress scene (night_city: 258 lights) and in
// the golden scene (spheres: 3 lights), drawn on lavapipe with the default pack's Forward variants.
//
// Cost: median GPU time of the Forward pass over `frames` draws of the whole frame (pipelines and shadow maps
// made before; lavapipe runs on the CPU, so this is CPU time of the rasterizer and shaders). Error: the image
// against the reference the CPU shades in double for the same G-buffer (relative RMSE on the float output,
// pixels over 2/255 on the tone-mapped output). Lights per pixel: how many lights a pixel's loop visits.
//
//   kiln-frame-cost PACK_DIR DEBUG_PACK_DIR OUT.json [frames]
#include <algorithm>
#include <chrono>
#include <ctime>
#include <fstream>
#include <iostream>

#include <nlohmann/json.hpp>

#include "golden/golden.hpp"
#include "render/renderer.hpp"
#include "reference/scene_inputs.hpp"
#include "reference/scene_reference.hpp"

namespace {

using namespace kiln;
using nlohmann::json;

// Average number of lights the Forward+ loop visits per covered pixel (its tile's list length).
double tile_lights_per_pixel(const render::FrameSetup& frame, const render::GBuffer& g, uint32_t width, uint32_t tile) {
  double sum = 0;
  size_t covered = 0;
  for (size_t p = 0; p < g.position.rgba.size() / 4; ++p) {
    if (g.position.rgba[p * 4 + 3] != 1.0f) continue;
    size_t tx = (p % width) / tile, ty = (p / width) / tile;
    sum += frame.tile_lists[(ty * frame.tiles_x + tx) * render::kTileStride];
    ++covered;
  }
  return covered ? sum / covered : 0;
}

json measure_scene(render::VulkanContext& context, const PackReader& pack,
                   const std::filesystem::path& scene_file, int frames) {
  render::Scene scene = render::load_scene(scene_file);
  render::SceneRenderer renderer(context, pack, scene);
  reference::SceneInputs reference_inputs(renderer.scene());  // the variants below all use one cascade
  const render::GBuffer& gbuffer = reference_inputs.gbuffer();
  const render::FrameSetup& frame = renderer.frame(1);
  const double lights = double(renderer.scene().lights.size());

  struct Row {
    const char* name;
    std::vector<std::string> keywords;
    double lights_per_pixel;
    const char* note;
  };
  const std::vector<Row> rows = {
      {"no additional lights", {}, 0, "the rest of the frame: sun, environment, fog"},
      {"plain loop (_ADDITIONAL_LIGHTS)", {"_ADDITIONAL_LIGHTS"}, lights, "every light, every pixel"},
      {"Forward+ (_ADDITIONAL_LIGHTS _FORWARD_PLUS)", {"_ADDITIONAL_LIGHTS", "_FORWARD_PLUS"},
       tile_lights_per_pixel(frame, gbuffer, renderer.width(), renderer.scene().tile_size),
       "conservative CPU tile lists, 16x16 pixels"},
      {"per vertex (_ADDITIONAL_LIGHTS_VERTEX)", {"_ADDITIONAL_LIGHTS_VERTEX"}, 0,
       "at most 8 lights, Lambert only, evaluated per vertex and interpolated (as URP)"},
  };
  json out;
  out["scene"] = scene.name;
  out["size"] = {renderer.width(), renderer.height()};
  out["lights"] = lights;
  out["frames"] = frames;
  for (const Row& row : rows) {
    SelectedVariant variant = pack.select("Forward", row.keywords);
    render::Image image = renderer.render(variant);  // compiles the pipeline
    std::vector<double> ms;
    for (int i = 0; i < frames; ++i) {
      image = renderer.render(variant);
      ms.push_back(renderer.last_draw_ms());
    }
    std::sort(ms.begin(), ms.end());
    // The per-vertex row is measured against the full per-pixel shading of every light: its error is what the
    // keyword gives up (the 8-light cap, specular, interpolation).
    std::vector<std::string> exact = row.keywords;
    std::replace(exact.begin(), exact.end(), std::string("_ADDITIONAL_LIGHTS_VERTEX"), std::string("_ADDITIONAL_LIGHTS"));
    render::Image reference = reference::shade_image(reference_inputs.inputs(exact), exact);
    render::ComparisonLimits limits{2, 1.0, 1.0, 255, 1.0, {}};  // measures only
    render::Comparison c = render::compare_images(image, reference, false, limits);
    out["variants"].push_back({{"name", row.name},
                               {"keywords", row.keywords},
                               {"draw_ms_median", ms[ms.size() / 2]},
                               {"draw_ms_min", ms.front()},
                               {"draw_ms_max", ms.back()},
                               {"lights_per_pixel", row.lights_per_pixel},
                               {"relative_rmse", c.relative_rmse},
                               {"fraction_over_2", c.fraction_over},
                               {"max_difference", c.max_difference},
                               {"note", row.note}});
    std::cout << scene.name << ": " << row.name << ": " << ms[ms.size() / 2] << " ms, RMSE " << c.relative_rmse << "\n";
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: kiln-frame-cost PACK_DIR OUT.json [frames]\n";
    return 1;
  }
  const int frames = argc > 3 ? std::max(3, std::atoi(argv[3])) : 9;
  try {
    auto opened = render::VulkanContext::open_lavapipe();
    if (!opened) throw std::runtime_error(opened.error().message);
    auto context = std::move(*opened);
    PackReader pack = PackReader::open(argv[1]);
    const std::filesystem::path scenes = std::filesystem::path(KILN_SOURCE_DIR) / "variants/scenes/render";
    json out;
    out["device"] = context->device_name() + " (" + context->driver_info() + ")";
    std::time_t now = std::time(nullptr);
    char date[32];
    std::strftime(date, sizeof date, "%Y-%m-%d", std::gmtime(&now));
    out["date"] = date;
    for (const char* scene : {"night_city.json", "spheres.json"})
      out["scenes"].push_back(measure_scene(*context, pack, scenes / scene, frames));
    std::ofstream(argv[2]) << out.dump(1) << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "kiln-frame-cost: error: " << e.what() << "\n";
    return 1;
  }
}
