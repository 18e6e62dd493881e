// What folding a keyword costs at run time (docs/keywords.md): the same variants drawn on lavapipe from packs that
// build the folded keywords as variants (a module each), as dynamic branches (a uniform bool) and as
// specialization constants (set when the pipeline is made), rounds interleaved, medians. Also the largest
// difference between each folded pack's image and the variant pack's: folding must not change a pixel beyond
// what a different compile of the same formulas may.
//
// Cost: median GPU time of the Forward pass over `frames` draws per round (pipelines and shadow maps made before;
// lavapipe runs on the CPU, so this is CPU time of the rasterizer and shaders).
//
//   kiln-fold-cost CONFIG.json OUT.json
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

namespace {

using namespace kiln;
using nlohmann::json;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v.size() % 2 ? v[v.size() / 2] : (v[v.size() / 2 - 1] + v[v.size() / 2]) / 2;
}

float largest_difference(const render::Image& a, const render::Image& b) {
  float worst = 0;
  for (size_t i = 0; i < a.rgba.size() && i < b.rgba.size(); ++i) {
    const float scale = std::max({std::fabs(a.rgba[i]), std::fabs(b.rgba[i]), 1e-3f});
    worst = std::max(worst, std::fabs(a.rgba[i] - b.rgba[i]) / scale);
  }
  return worst;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: kiln-fold-cost CONFIG.json OUT.json\n";
    return 1;
  }
  try {
    const json config = json::parse(std::ifstream(argv[1]));
    const int frames = std::max(3, config.value("frames", 15));
    const int rounds = std::max(1, config.value("rounds", 5));
    auto opened = render::VulkanContext::open_lavapipe();
    if (!opened) throw std::runtime_error(opened.error().message);
    auto context = std::move(*opened);
    const render::Scene scene = render::load_scene(config.at("scene").get<std::string>());
    struct Pack {
      std::string kind;
      std::unique_ptr<PackReader> reader;
      std::unique_ptr<render::SceneRenderer> renderer;
    };
    std::vector<Pack> packs;
    for (const json& p : config.at("packs")) {
      Pack pack{p.at("kind").get<std::string>(), std::make_unique<PackReader>(PackReader::open(p.at("dir").get<std::string>())), nullptr};
      pack.renderer = std::make_unique<render::SceneRenderer>(*context, *pack.reader, scene);
      packs.push_back(std::move(pack));
    }
    const json& rows = config.at("rows");
    // ms[row][pack]: every frame of every round; images of the first round, for the differences.
    std::vector<std::vector<std::vector<double>>> ms(rows.size(), std::vector<std::vector<double>>(packs.size()));
    std::vector<std::vector<render::Image>> images(rows.size(), std::vector<render::Image>(packs.size()));
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
      std::cout << rows[r].at("name").get<std::string>();
      for (size_t p = 0; p < packs.size(); ++p)
        std::cout << "  " << packs[p].kind << " " << median(ms[r][p]) << " ms (" << median(ms[r][p]) / base << "x)";
      std::cout << "\n";
      out["rows"].push_back(std::move(row));
    }
    std::ofstream(argv[2]) << out.dump(1) << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "kiln-fold-cost: error: " << e.what() << "\n";
    return 1;
  }
}
