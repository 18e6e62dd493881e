#include "common/target_environment.hpp"
#include "driver/write_pack.hpp"

#include "cross/cross_compile.hpp"
#include "driver/outputs.hpp"
#include "driver/stage_timer.hpp"
#include "kiln/pack_format.hpp"
#include "optimize/spirv_tools.hpp"
#include "pack/pack_writer.hpp"

namespace kiln {
namespace {

using nlohmann::json;

json keyword_group_json(const KeywordGroup& group) {
  json values = json::array();
  for (const std::string& v : group.values) values.push_back(v.empty() ? "_" : v);
  json stages = json::array();
  for (Stage s : kAllStages)
    if (group.stages & stage_bit(s)) stages.push_back(stage_name(s));
  return {{"pragma", group.pragma}, {"values", values}, {"stages", stages}};
}

// Recorded in the manifest so that tools (check-scene) can reason about a built pack on its own.
json constraints_json(const PackDefinition& pack) {
  json out = json::array();
  for (const Constraint& c : pack.constraints) {
    json item{{"keyword", c.keyword}};
    if (!c.requires_all.empty()) item["requires"] = c.requires_all;
    if (!c.requires_any.empty()) item["requires_any"] = c.requires_any;
    if (!c.excludes.empty()) item["excludes"] = c.excludes;
    if (!c.reason.empty()) item["reason"] = c.reason;
    out.push_back(item);
  }
  return out;
}

json materials_json(const PackDefinition& pack) {
  json out = json::array();
  for (const MaterialPreset& m : pack.materials) out.push_back({{"name", m.name}, {"keywords", m.keywords}});
  return out;
}

// The binding options and defines a pass was built with, when not the defaults (docs/bindings.md): absent
// fields keep the manifests of packs that use neither as they were.
void add_pass_settings_json(json& pass_json, const PassDefinition& pass) {
  if (!pass.bindings.canonical().empty()) pass_json["bindings"] = pass.bindings.canonical();
  if (!pass.defines.empty()) {
    json defines = json::object();
    for (const Define& define : pass.defines) defines[define.name] = define.value;
    pass_json["defines"] = defines;
  }
}

}  // namespace

std::optional<std::string> write_variant_pack(const Plan& plan, const BuildOptions& options, const BuildSettings& settings,
                        const StageSources& sources, const std::vector<Binary>& binaries,
                        const std::vector<nlohmann::json>& layouts, const std::string& inputs_hash, DiagnosticSink& sink,
                        BuildReport& report) {
  StageTimer timer(report, "pack");
  ArchiveBuilder archive;
  std::map<size_t, size_t> binary_order;         // compile index -> manifest binary index
  std::map<Hash128, size_t> binary_by_output;    // identical outputs from different sources are stored once
  std::map<Hash128, size_t> reflection_by_hash;  // most binaries of a pass share one reflection
  json binaries_json = json::array();
  json reflections_json = json::array();
  json passes_json = json::array();
  for (uint32_t p = 0; p < plan.passes.size(); ++p) {
    const PassDefinition& def = plan.pack.passes[p];
    json stages = json::object();
    for (Stage s : kAllStages)
      if (!def.entry_points[static_cast<size_t>(s)].empty())
        stages[std::string(stage_name(s))] = def.entry_points[static_cast<size_t>(s)];
    json groups = json::array();
    for (const KeywordGroup& g : plan.passes[p].groups) groups.push_back(keyword_group_json(g));
    json variants = json::array();
    const auto& expansion = plan.expansions[p];
    for (size_t v = 0; v < expansion.variants.size(); ++v) {
      json stage_binaries = json::object();
      for (Stage s : kAllStages) {
        int source = sources.variant_source[p][v][static_cast<size_t>(s)];
        if (source < 0) continue;
        size_t b = static_cast<size_t>(sources.list[static_cast<size_t>(source)].binary);
        auto known = binary_order.find(b);
        if (known == binary_order.end()) {
          const JobOutput& out = *binaries[b].output;
          const Hash128 spirv = out.blobs.at(Target::Spirv).key;
          Hash128 output_key =
              Hasher().add(stage_name(binaries[b].stage)).add(binaries[b].entry_point).add(spirv.low).add(spirv.high).finish();
          auto [by_output, fresh] = binary_by_output.emplace(output_key, binaries_json.size());
          if (fresh) {
            json blobs = json::object();
            for (const auto& [target, blob] : out.blobs) blobs[std::string(target_name(target))] = archive.add(blob);
            std::string reflection_text = out.reflection.dump();
            auto [reflection, new_reflection] = reflection_by_hash.emplace(hash128(reflection_text), reflections_json.size());
            if (new_reflection) reflections_json.push_back(out.reflection);
            binaries_json.push_back({{"stage", stage_name(binaries[b].stage)},
                                     {"entry", binaries[b].entry_point},
                                     {"blobs", blobs},
                                     {"reflection", reflection->second}});
          }
          known = binary_order.emplace(b, by_output->second).first;
        }
        stage_binaries[std::string(stage_name(s))] = known->second;
      }
      variants.push_back({{"keywords", enabled_keywords(plan.passes[p].groups, expansion.variants[v])},
                          {"binaries", stage_binaries}});
    }
    json pass_json{{"name", def.name},
                   {"stages", stages},
                   {"keyword_groups", groups},
                   {"layout", layouts[p]},
                   {"variants", variants}};
    add_pass_settings_json(pass_json, def);
    passes_json.push_back(std::move(pass_json));
  }
  json target_list_json = json::array();
  for (Target t : settings.targets) target_list_json.push_back(target_name(t));
  report.funnel.unique_binaries = binaries_json.size();
  const Funnel& f = report.funnel;
  json manifest{{"format", kManifestFormat},
                {"format_version", kPackFormatVersion},
                {"name", plan.pack.name},
                {"kiln_version", kKilnVersion},
                {"tools", {{"frontend", settings.frontend->name() + " " + settings.frontend->version()},
                           {"spirv_tools", spirv_tools_version()},
                           {"spirv_cross", spirv_cross_version()}}},
                {"options", {{"optimize", options.optimize},
                             {"optimizer_recipe", optimizer_recipe_name(options.optimizer_recipe)},
                             {"targets", target_list_json},
                             {"spirv_env", kTargetEnvironment.spirv_env},
                             {"glsl_version", kTargetEnvironment.glsl_version}, {"gles_version", kTargetEnvironment.gles_version},
                             {"msl_version", kTargetEnvironment.msl_version},
                             {"gl_clip_space_fixup", kTargetEnvironment.gl_clip_space_fixup}}},
                {"inputs_hash", inputs_hash},
                {"funnel", {{"declared", f.declared}, {"valid", f.valid}, {"kept", f.kept},
                            {"stage_instances", f.stage_instances}, {"unique_preprocessed", f.unique_preprocessed},
                            {"unique_compiles", f.unique_compiles}, {"unique_modules", f.unique_modules},
                            {"unique_binaries", f.unique_binaries}}},
                {"constraints", constraints_json(plan.pack)},
                {"materials", materials_json(plan.pack)},
                {"scene_features", plan.pack.scene_features_json.empty() ? json::object()
                                                                        : json::parse(plan.pack.scene_features_json)},
                {"passes", passes_json},
                {"binaries", binaries_json},
                {"reflections", reflections_json}};
  WrittenPack written = write_pack(options.output_dir, plan.pack.name, archive, manifest);
  if (!written.error.empty()) {
    sink.report(DiagId::OutputUnwritable, SourceLocation{options.output_dir.string(), 0, 0}, written.error);
    return std::nullopt;
  }
  // Last: the stamp that lets the next build with the same inputs skip everything. Without it the next build
  // only works again; the pack is whole.
  if (std::string error = write_stamp(options.output_dir, plan.pack.name, written.archive_file, inputs_hash); !error.empty()) {
    sink.report(DiagId::OutputUnwritable, SourceLocation{options.output_dir.string(), 0, 0}, error);
    return std::nullopt;
  }
  return written.archive_file;
}

}  // namespace kiln
