// SPDX-License-Identifier: Apache-2.0
#include "common/target_environment.hpp"
#include "driver/write_pack.hpp"

#include "cross/targets.hpp"
#include "driver/outputs.hpp"
#include "driver/build_context.hpp"
#include "kiln/pack_format.hpp"
#include "kiln/runtime_index.hpp"
#include "optimize/spirv_tools.hpp"
#include "pack/pack_writer.hpp"

namespace kiln {
namespace {


// The binding options and defines a pass was built with, when not the defaults (docs/bindings.md): empty fields
// are left out of the file, which keeps the manifests of packs that use neither as they were.
void add_pass_settings(ManifestPass& record, const PassDefinition& pass) {
  record.bindings = pass.bindings.canonical();
  for (Stage stage : kAllStages)
    if (const auto& own = pass.stage_bindings[static_cast<size_t>(stage)]; own && own->canonical() != record.bindings) {
      const std::string text = own->canonical();
      record.bindings += (record.bindings.empty() ? "" : " ") + ("[" + std::string(stage_name(stage)) + ": " +
                         (text.empty() ? std::string("defaults") : text) + "]");
    }
  for (const Define& define : pass.defines) record.defines[define.name] = define.value;
}

ManifestOptions option_records(const BuildSettings& settings) {
  ManifestOptions out;
  out.optimize = settings.optimize;
  out.optimizer_recipe = optimizer_recipe_name(settings.optimizer_recipe);
  out.targets = settings.targets;
  out.spirv_env = kTargetEnvironment.spirv_env;
  for (const TargetBackend& backend : target_backends()) backend.record_options(out);
  return out;
}

}  // namespace

std::optional<WrittenVariantPack> write_variant_pack(BuildContext& build, const Plan& plan, const BuildSettings& settings,
                                                    const StageSources& sources, const std::vector<Binary>& binaries,
                                                    const std::vector<PassLayout>& layouts, const std::string& inputs_hash,
                                                    const Funnel& funnel, const std::filesystem::path& output_dir) {
  StageTimer timer(build, "pack");
  DiagnosticSink& sink = build.sink;
  ArchiveBuilder archive;
  Manifest manifest;
  std::map<size_t, uint32_t> binary_order;       // compile index -> manifest binary index
  std::map<Hash128, uint32_t> binary_by_output;  // identical outputs from different sources are stored once
  std::map<Hash128, uint32_t> reflection_by_hash;  // most binaries of a pass share one reflection
  for (uint32_t p = 0; p < plan.passes.size(); ++p) {
    const PassDefinition& def = plan.pack.passes[p];
    ManifestPass& pass = manifest.passes.emplace_back();
    pass.name = def.name;
    if (!def.targets.empty()) pass.targets = settings.targets_for(def);
    for (Stage s : kAllStages)
      if (!def.entry_points[static_cast<size_t>(s)].empty()) pass.entry_points[s] = def.entry_points[static_cast<size_t>(s)];
    pass.keyword_groups = plan.keyword_group_records(p);
    pass.layout = layouts[p];
    const auto& expansion = plan.expansions[p];
    for (size_t v = 0; v < expansion.variants.size(); ++v) {
      ManifestVariant& variant = pass.variants.emplace_back();
      variant.keywords = enabled_keywords(plan.passes[p].groups, expansion.variants[v]);
      for (Stage s : kAllStages) {
        int source = sources.variant_source[p][v][static_cast<size_t>(s)];
        if (source < 0) continue;
        size_t b = static_cast<size_t>(sources.list[static_cast<size_t>(source)].binary);
        auto known = binary_order.find(b);
        if (known == binary_order.end()) {
          const JobOutput& out = *binaries[b].output;
          const Hash128 spirv = out.blobs.at(Target::Spirv).key;
          // Binaries with the same SPIR-V are one, unless one was built for targets the other was not (passes with
          // their own "targets").
          Hasher same_output;
          same_output.add(stage_name(binaries[b].stage)).add(binaries[b].entry_point).add(spirv.low).add(spirv.high);
          for (const auto& [target, blob] : out.blobs) same_output.add(target_name(target));
          Hash128 output_key = same_output.finish();
          const auto binary_index = static_cast<uint32_t>(manifest.binaries.size());
          auto [by_output, fresh] = binary_by_output.emplace(output_key, binary_index);
          if (fresh) {
            ManifestBinary& record = manifest.binaries.emplace_back();
            record.stage = binaries[b].stage;
            record.entry = binaries[b].entry_point;
            for (const auto& [target, blob] : out.blobs) record.blobs[target] = archive.add_borrowed(blob);
            const auto reflection_index = static_cast<uint32_t>(manifest.reflections.size());
            auto [reflection, new_reflection] =
                reflection_by_hash.emplace(hash128(runtime::encode_reflection(out.reflection)), reflection_index);
            if (new_reflection) manifest.reflections.push_back(out.reflection);
            record.reflection = reflection->second;
          }
          known = binary_order.emplace(b, by_output->second).first;
        }
        variant.binaries[s] = known->second;
      }
    }
    add_pass_settings(pass, def);
  }
  Funnel f = funnel;
  f.unique_binaries = manifest.binaries.size();
  manifest.format_version = kPackFormatVersion;
  manifest.name = plan.pack.name;
  manifest.kiln_version = kKilnVersion;
  manifest.tools = {settings.frontend->name() + " " + settings.frontend->version(), spirv_tools_version(), spirv_cross_version()};
  manifest.options = option_records(settings);
  manifest.inputs_hash = inputs_hash;
  manifest.funnel = f;  // the manifest's part of the build's funnel
  // Recorded so that tools (check-scene) can reason about a built pack on its own: each as the definition has it,
  // less where it is defined.
  manifest.constraints.assign(plan.pack.constraints.begin(), plan.pack.constraints.end());
  manifest.materials.assign(plan.pack.materials.begin(), plan.pack.materials.end());
  if (!plan.pack.scene_features_json.empty()) manifest.scene_features_json = plan.pack.scene_features_json;
  PackFiles files;
  Result<std::string> archive_file = write_pack(output_dir, plan.pack.name, archive, std::move(manifest), &files);
  if (!archive_file) {
    sink.report(DiagId::OutputUnwritable, SourceLocation{output_dir.string(), 0, 0}, archive_file.error().message);
    return std::nullopt;
  }
  // Last: the stamp that lets the next build with the same inputs skip everything. Without it the next build
  // only works again; the pack is whole.
  if (Result<void> stamped = write_stamp(output_dir, plan.pack.name, *archive_file, inputs_hash); !stamped) {
    sink.report(DiagId::OutputUnwritable, SourceLocation{output_dir.string(), 0, 0}, stamped.error().message);
    return std::nullopt;
  }
  return WrittenVariantPack{*archive_file, f.unique_binaries, std::move(files)};
}

}  // namespace kiln
