// Loading pack definitions (variants/*.pack.json) and scene profiles (variants/scenes/*.json).
#pragma once

#include <functional>
#include <optional>
#include <string_view>
#include <vector>

#include "common/files.hpp"
#include "kiln/model.hpp"

namespace kiln {

// The fields each object of a pack definition and of a scene profile may have; any other is an error (a
// misspelled "budjet" must not silently mean the default budget). variants/schema/ lists the same fields
// (checked by unit.Definition tests).
struct DefinitionFields {
  std::vector<std::string_view> pack, pass, constraint, material, scene, bindings, shift;
};
const DefinitionFields& definition_fields();

std::optional<PackDefinition> load_pack_definition(const std::filesystem::path& file, const ReadLimits& limits,
                                                   DiagnosticSink& sink);
std::optional<SceneProfile> load_scene_profile(const std::filesystem::path& file, const ReadLimits& limits,
                                               DiagnosticSink& sink);

// The command line's binding options and defines, applied to every pass (they win over the pack's).
void apply_command_line(PackDefinition& pack, const BindingOptions& bindings, const std::vector<Define>& defines);

// The command line's spellings (docs/bindings.md): "NAME[=VALUE]" for -D; "N SPACE" (SPACE a number or
// "all") for -fvk-<class>-shift; "N M" for -fvk-bind-globals. Errors are K1014, at "<command line>".
std::optional<std::vector<Define>> parse_command_line_defines(const std::vector<std::string>& texts, DiagnosticSink& sink);
bool parse_command_line_shift(RegisterClass register_class, const std::string& shift, const std::string& space,
                              BindingOptions& options, DiagnosticSink& sink);
bool parse_command_line_globals(const std::string& binding, const std::string& set, BindingOptions& options,
                                DiagnosticSink& sink);

// Turns a profile's "uses" and "materials" into keywords with the pack's scene_features table and
// material presets (both as JSON text, as recorded in a pack definition or a manifest).
// --shard I/N (0 <= I < N), or auto, read from the scheduler's variables through `environment` (getenv, or a
// test's): Slurm job arrays (SLURM_ARRAY_TASK_ID with SLURM_ARRAY_TASK_COUNT, or with SLURM_ARRAY_TASK_MIN/MAX),
// GitLab parallel jobs (CI_NODE_INDEX, 1-based, and CI_NODE_TOTAL), Kubernetes Indexed Jobs (JOB_COMPLETION_INDEX
// with KILN_SHARD_COUNT, which the job sets to its completions). Empty, or the error.
std::string parse_shard_option(const std::string& text, const std::function<const char*(const char*)>& environment,
                               unsigned& shard_index, unsigned& shard_count);

bool resolve_scene_profile(SceneProfile& scene, const std::string& scene_features_json,
                           const std::vector<MaterialPreset>& materials, DiagnosticSink& sink);

}  // namespace kiln
