// SPDX-License-Identifier: Apache-2.0
// The preprocessed stage sources `kiln build --emit preprocessed` wrote for a pack, in a fixed order: what the
// floor and per-pass benchmarks (compile_steps.cpp, optimizer_passes.cpp) run the libraries on.
#pragma once

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "kiln/model.hpp"

namespace kiln::bench {

struct EmittedSource {
  std::string stage_name;  // "vertex", "fragment"
  Stage stage = Stage::Fragment;
  std::string entry;
  std::filesystem::path path;
};

// Every `<emit_dir>/<pass>/<stage>/*.hlsl` of the pack's passes, by pass, stage and file name.
inline std::vector<EmittedSource> emitted_sources(const std::string& emit_dir, const std::string& pack_file) {
  std::ifstream in(pack_file);
  std::stringstream text;
  text << in.rdbuf();
  const nlohmann::json pack = nlohmann::json::parse(text.str());
  std::vector<EmittedSource> out;
  for (const auto& pass : pack.at("passes")) {
    for (const auto& [stage_name, entry] : pass.at("stages").items()) {
      const std::filesystem::path dir = std::filesystem::path(emit_dir) / pass.at("name").get<std::string>() / stage_name;
      std::vector<std::filesystem::path> sources;
      for (const auto& file : std::filesystem::directory_iterator(dir))
        if (file.path().extension() == ".hlsl") sources.push_back(file.path());
      std::sort(sources.begin(), sources.end());
      for (const auto& source : sources)
        out.push_back({stage_name, parse_stage(stage_name).value_or(Stage::Fragment), entry.get<std::string>(), source});
    }
  }
  return out;
}

}  // namespace kiln::bench
