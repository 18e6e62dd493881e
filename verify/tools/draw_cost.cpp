// SPDX-License-Identifier: Apache-2.0
// kiln-verify draw-cost (run by `kiln fold-cost --render-scene`, docs/keywords.md): the same variants drawn on
// lavapipe from packs that build some keywords as variants (a module each), dynamic branches (a uniform bool) or
// specialization constants (set when the pipeline is made), rounds interleaved, medians. Also the largest
// difference between each pack's image and the first pack's: folding must not change a pixel beyond what a
// different compile of the same formulas may (a shader not written for folding does).
//
// Cost: median GPU time of the Forward pass over `frames` draws per round (pipelines and shadow maps made before;
// lavapipe runs on the CPU, so this is CPU time of the rasterizer and shaders).
//
//   kiln-verify draw-cost CONFIG.json OUT.json
//   CONFIG: {"scene": "...json", "frames": 15, "rounds": 5,
//            "packs": [{"kind": "variant", "dir": "..."}, {"kind": "dynamic_branch", "dir": "..."}, ...],
//            "rows": [{"name": "_SHADOWS_SOFT on", "keywords": ["_MAIN_LIGHT_SHADOWS", "_SHADOWS_SOFT"]}, ...]}
#include <algorithm>
#include <cmath>
#include <ctime>
#include <fstream>
#include <iostream>
#include <memory>

#include <nlohmann/json.hpp>

#include "render/renderer.hpp"
#include "scene/image.hpp"
#include "scene/verify_error.hpp"
#include "tools/draw_cost.hpp"

namespace kiln::render {
namespace {

using nlohmann::json;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v.size() % 2 ? v[v.size() / 2] : (v[v.size() / 2 - 1] + v[v.size() / 2]) / 2;
}

float largest_difference(const Image& a, const Image& b) {
  float worst = 0;
  for (size_t i = 0; i < a.rgba.size() && i < b.rgba.size(); ++i) {
    const float scale = std::max({std::fabs(a.rgba[i]), std::fabs(b.rgba[i]), 1e-3f});
    worst = std::max(worst, std::fabs(a.rgba[i] - b.rgba[i]) / scale);
  }
  return worst;
}

}  // namespace

int run_draw_cost(const std::string& config_file, const std::string& out_file) {
  return reporting_errors([&] {
    std::ifstream config_in(config_file);
    if (!config_in) fail(DiagId::VerifyArgument, {}, "cannot read " + config_file);
    const json config = json::parse(config_in, nullptr, /*allow_exceptions=*/false);
    if (!config.is_object() || !config.contains("scene") || !config.contains("packs") || !config.contains("rows"))
      fail(DiagId::VerifyArgument, {}, config_file + " is not a draw-cost configuration (scene, packs, rows)");
    const int frames = std::max(3, config.value("frames", 15));
    const int rounds = std::max(1, config.value("rounds", 5));
    auto opened = VulkanContext::open_lavapipe();
    if (!opened) fail(DiagId::VerifyArgument, {}, opened.error().message);
    auto context = std::move(*opened);
    const Scene scene = load_scene(config.at("scene").get<std::string>());
    struct Pack {
      std::string kind;
      std::unique_ptr<PackReader> reader;
      std::unique_ptr<SceneRenderer> renderer;
    };
    std::vector<Pack> packs;
    for (const json& p : config.at("packs")) {
      Pack pack{p.at("kind").get<std::string>(), std::make_unique<PackReader>(PackReader::open(p.at("dir").get<std::string>())), nullptr};
      pack.renderer = std::make_unique<SceneRenderer>(*context, *pack.reader, scene);
      packs.push_back(std::move(pack));
    }
    const json& rows = config.at("rows");
    // ms[row][pack]: every frame of every round; images of the first round, for the differences.
    std::vector<std::vector<std::vector<double>>> ms(rows.size(), std::vector<std::vector<double>>(packs.size()));
    std::vector<std::vector<Image>> images(rows.size(), std::vector<Image>(packs.size()));
    for (size_t r = 0; r < rows.size(); ++r)
      for (size_t p = 0; p < packs.size(); ++p)  // pipelines made, shadow maps drawn: not timed
        images[r][p] = packs[p].renderer->render(rows[r].at("keywords").get<std::vector<std::string>>());
    for (int round = 0; round < rounds; ++round)
      for (size_t r = 0; r < rows.size(); ++r) {
        const auto keywords = rows[r].at("keywords").get<std::vector<std::string>>();
        for (size_t p = 0; p < packs.size(); ++p) {
          const size_t pack = (p + round + r) % packs.size();  // which pack goes first rotates
          const SelectedVariant variant = packs[pack].reader->select("Forward", keywords);
          for (int f = 0; f < frames; ++f) {
            packs[pack].renderer->render(variant);
            ms[r][pack].push_back(packs[pack].renderer->last_draw_ms());
          }
        }
        std::cerr << "round " << round + 1 << "/" << rounds << ": " << rows[r].at("name").get<std::string>() << "\n";
      }
    json out;
    out["device"] = context->device_name() + " (" + context->driver_info() + ")";
    std::time_t now = std::time(nullptr);
    char date[32];
    std::strftime(date, sizeof date, "%Y-%m-%d", std::gmtime(&now));
    out["date"] = date;
    out["scene"] = scene.name;
    out["frames"] = frames;
    out["rounds"] = rounds;
    for (size_t r = 0; r < rows.size(); ++r) {
      json row = {{"name", rows[r].at("name")}, {"keywords", rows[r].at("keywords")}};
      const double base = median(ms[r][0]);
      for (size_t p = 0; p < packs.size(); ++p) {
        row["draw_ms_median"][packs[p].kind] = median(ms[r][p]);
        row["ratio"][packs[p].kind] = median(ms[r][p]) / base;
        row["largest_relative_difference"][packs[p].kind] = largest_difference(images[r][p], images[r][0]);
      }
      out["rows"].push_back(std::move(row));
    }
    write_output(out_file, out.dump(1) + "\n");
    return 0;
  });
}

}  // namespace kiln::render
