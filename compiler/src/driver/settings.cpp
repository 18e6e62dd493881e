// SPDX-License-Identifier: Apache-2.0
#include "driver/settings.hpp"

#include <algorithm>

#include "cross/targets.hpp"
#include "kiln/pack_format.hpp"
#include "optimize/spirv_tools.hpp"
#include "workers/compile_job.hpp"

namespace kiln {

std::optional<BuildSettings> choose_settings(const BuildOptions& options, const Plan& plan, DiagnosticSink& sink) {
  BuildSettings settings;
  settings.frontend = make_frontend(options.frontend);
  if (!settings.frontend) {
    std::string known;
    for (const std::string& name : frontend_names()) known += (known.empty() ? "" : ", ") + name;
    sink.report(DiagId::UnknownFrontend, SourceLocation{options.pack_file.string(), 0, 0},
                "no front end named '" + options.frontend + "' (kiln has: " + known + ")");
    return std::nullopt;
  }
  settings.fingerprint = std::string("kiln ") + kKilnVersion + " (compile job revision " + std::to_string(kCompileJobRevision) +
                         "); " + settings.frontend->name() + " " + settings.frontend->version() + "; " +
                         spirv_tools_version() + "; SPIRV-Cross " + spirv_cross_version();
  settings.targets = options.targets.empty() ? plan.pack.targets : options.targets;
  settings.targets_from_command_line = !options.targets.empty();
  if (std::find(settings.targets.begin(), settings.targets.end(), Target::Spirv) == settings.targets.end())
    settings.targets.insert(settings.targets.begin(), Target::Spirv);
  std::sort(settings.targets.begin(), settings.targets.end());
  for (Target t : settings.targets) settings.target_names += std::string(target_name(t)) + ",";
  settings.optimize = options.optimize && !options.coverage;  // the lines of the source, not of the optimizer's code
  settings.debug_info = options.debug_info || options.coverage;
  settings.coverage = options.coverage;
  settings.optimizer_recipe = options.optimizer_recipe;
  return settings;
}

std::string hash_inputs(const BuildSettings& settings, const Plan& plan) {
  Hasher inputs;
  add_build_inputs(inputs, settings, plan);
  return inputs.finish().hex();
}

}  // namespace kiln
