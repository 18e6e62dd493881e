// SPDX-License-Identifier: Apache-2.0
// Loading pack definitions (variants/*.pack.json) and scene profiles (variants/scenes/*.json).
#pragma once

#include <functional>
#include <optional>
#include <string_view>
#include <vector>

#include "common/files.hpp"
#include "kiln/model.hpp"
#include "kiln/command_line.hpp"

namespace kiln {

// The fields each object of a pack definition and of a scene profile may have; any other is an error (a
// misspelled "budjet" must not silently mean the default budget). They are the rows of definition.cpp's field
// tables, which read them; variants/schema/ lists the same fields (checked by unit.Definition tests).
struct DefinitionFields {
  std::vector<std::string_view> pack, pass, constraint, material, scene, bindings, shift, lint, stage;
};
const DefinitionFields& definition_fields();

std::optional<PackDefinition> load_pack_definition(const std::filesystem::path& file, const ReadLimits& limits,
                                                   DiagnosticSink& sink);
std::optional<SceneProfile> load_scene_profile(const std::filesystem::path& file, const ReadLimits& limits,
                                               DiagnosticSink& sink);

// The command line's binding options and defines, applied to every pass (they win over the pack's).
void apply_command_line(PackDefinition& pack, const BindingOptions& bindings, const std::vector<Define>& defines);

// Turns a profile's "uses" and "materials" into keywords with the pack's scene_features table and
// material presets (both as JSON text, as recorded in a pack definition or a manifest).
bool resolve_scene_profile(SceneProfile& scene, const std::string& scene_features_json,
                           const std::vector<MaterialPreset>& materials, DiagnosticSink& sink);

}  // namespace kiln
