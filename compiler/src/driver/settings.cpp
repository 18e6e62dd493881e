#include "driver/settings.hpp"

#include <algorithm>

#include "cross/cross_compile.hpp"
#include "kiln/pack_format.hpp"
#include "optimize/spirv_tools.hpp"
#include "workers/compile_job.hpp"

namespace kiln {

// "binding model 1" marks keys made since kiln's own resolver assigns glslang's bindings (a resource without a
// register was at binding 0 before): cache entries of older builds are not reused. It is not a
// kCompileJobRevision bump because that revision is in the inputs hash, which the manifest records: packs whose
// bindings did not change keep their bytes.
Hasher& BuildSettings::add_compile_options(Hasher& hasher, const PassDefinition& pass, Stage stage) const {
  return hasher.add(fingerprint).add(optimize ? 1 : 0).add(target_names).add(stage_name(stage))
      .add(pass.entry_points[static_cast<size_t>(stage)]).add("binding model 1").add(pass.bindings.canonical());
}

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
  if (std::find(settings.targets.begin(), settings.targets.end(), Target::Spirv) == settings.targets.end())
    settings.targets.insert(settings.targets.begin(), Target::Spirv);
  std::sort(settings.targets.begin(), settings.targets.end());
  for (Target t : settings.targets) settings.target_names += std::string(target_name(t)) + ",";
  settings.optimize = options.optimize;
  return settings;
}

std::string hash_inputs(const BuildSettings& settings, const Plan& plan, const BuildOptions& options) {
  Hasher inputs;
  inputs.add(uint64_t{kPackFormatVersion});
  inputs.add(settings.fingerprint).add(settings.optimize ? 1 : 0).add(settings.target_names).add(plan.pack.text);
  for (const SceneProfile& scene : plan.scenes) inputs.add(scene.text);
  // The pack's own bindings and defines are in its text; the command line's are added when given (a build
  // without them keeps the inputs hash, and so the manifest, it always had).
  if (!options.bindings.canonical().empty()) inputs.add("bindings").add(options.bindings.canonical());
  for (const Define& define : options.defines) inputs.add("define").add(define.name).add(define.value);
  for (const auto& [path, file] : plan.sources.files) inputs.add(path.string()).add(file.text);
  return inputs.finish().hex();
}

}  // namespace kiln
