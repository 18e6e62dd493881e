// Loading pack definitions (variants/*.pack.json) and scene profiles (variants/scenes/*.json).
#pragma once

#include <optional>

#include "common/files.hpp"
#include "kiln/model.hpp"

namespace kiln {

std::optional<PackDefinition> load_pack_definition(const std::filesystem::path& file, const ReadLimits& limits,
                                                   DiagnosticSink& sink);
std::optional<SceneProfile> load_scene_profile(const std::filesystem::path& file, const ReadLimits& limits,
                                               DiagnosticSink& sink);

}  // namespace kiln
