// SPDX-License-Identifier: Apache-2.0
// Stages 0-3: definitions, declarations, expansion, stripping.
#include "driver/plan.hpp"


namespace kiln {

std::unique_ptr<Plan> make_plan(const BuildOptions& options, BuildContext& build) {
  DiagnosticSink& sink = build.sink;
  auto plan = std::make_unique<Plan>();
  plan->usage_margin = options.usage_margin;
  plan->command_line_bindings = options.bindings;
  plan->command_line_defines = options.defines;
  plan->command_line_kinds = options.keyword_kinds;
  ReadLimits limits{options.max_file_bytes};
  {
    StageTimer timer(build, "load");
    auto pack = load_pack_definition(options.pack_file, limits, sink);
    bool ok = pack.has_value();
    for (const auto& file : options.scene_files) {
      auto scene = load_scene_profile(file, limits, sink);
      if (scene) plan->scenes.push_back(std::move(*scene));
      else ok = false;
    }
    for (const auto& file : options.usage_logs) {
      auto log = load_usage_log(file, limits, sink);
      if (!log) ok = false;
      else if (usage_matches(*log, options.usage_tags)) plan->usage.push_back(std::move(*log));
    }
    if (ok && !options.usage_logs.empty() && plan->usage.empty()) {
      std::string tags;
      for (const auto& [key, value] : options.usage_tags) tags += (tags.empty() ? "" : ", ") + key + "=" + value;
      sink.report(DiagId::UsageLog, SourceLocation{"<command line>", 0, 0},
                  "none of the " + std::to_string(options.usage_logs.size()) + " usage logs has the tags " + tags);
      ok = false;
    }
    if (!ok) return nullptr;
    plan->pack = std::move(*pack);
    for (const UsageLog& log : plan->usage)
      if (log.pack != plan->pack.name) {
        sink.report(DiagId::UsageLog, usage_log_pack_location(log),
                    "this usage log is of pack '" + log.pack + "', not of '" + plan->pack.name + "'");
        ok = false;
      }
    if (!ok) return nullptr;
    apply_command_line(plan->pack, options.bindings, options.defines);
    for (const auto& [keyword, kind] : options.keyword_kinds) plan->pack.keyword_kinds[keyword] = {kind, SourceLocation{"<command line>", 0, 0}};
    for (SceneProfile& scene : plan->scenes)
      ok = resolve_scene_profile(scene, plan->pack.scene_features_json, plan->pack.materials, sink) && ok;
    if (!ok) return nullptr;
  }
  {
    StageTimer timer(build, "declarations");
    std::vector<std::filesystem::path> roots = plan->pack.include_dirs;
    // The directory of every file a pass names (its source, each stage's own file) is an include root.
    for (const PassDefinition& pass : plan->pack.passes) {
      std::vector<std::filesystem::path> named(pass.stage_sources.begin(), pass.stage_sources.end());
      named.push_back(pass.source);
      for (const std::filesystem::path& file : named)
        if (!file.empty() && std::find(roots.begin(), roots.end(), file.parent_path()) == roots.end())
          roots.push_back(file.parent_path());
    }
    plan->roots = std::make_unique<IncludeRoots>(roots);
    bool ok = true;
    for (PassDefinition& pass : plan->pack.passes) {
      bool exists = true;
      for (Stage stage : kAllStages) {
        const std::filesystem::path& file = pass.stage_sources[static_cast<size_t>(stage)];
        std::error_code ec;
        if (file.empty() || std::filesystem::exists(file, ec)) continue;
        const bool own = file != pass.source;
        sink.report(DiagId::FileUnreadable, pass.defined_at,
                    "pass '" + pass.name + "': " + (own ? "the " + std::string(stage_name(stage)) + " stage's " : "") +
                        "source file '" + file.string() + "' does not exist");
        exists = false;
        if (!own) break;  // once for the pass's own source
      }
      if (!exists) {
        ok = false;
        continue;
      }
      if (!apply_stage_pragmas(pass, *plan->roots, limits, plan->sources, sink)) {
        ok = false;
        continue;
      }
      auto declarations = scan_pass_declarations(pass, *plan->roots, limits, plan->sources, sink);
      if (!declarations) {
        ok = false;
        continue;
      }
      plan->passes.push_back(PassKeywords{&pass, declarations->groups});
      plan->declarations.push_back(std::move(*declarations));
    }
    if (!ok) return nullptr;
  }
  {
    StageTimer timer(build, "expand+strip");
    if (!apply_keyword_kinds(plan->passes, plan->pack, sink)) return nullptr;
    // A -D that names a folded keyword selects a variant (kiln compile writes that variant's code); it is no macro: the
    // module reads the keyword at run time, and the keyword's own macro (`K=K`) would clash with it.
    for (size_t p = 0; p < plan->passes.size(); ++p)
      for (const KeywordGroup& group : plan->passes[p].groups)
        if (is_folded(group.kind()))
          std::erase_if(plan->pack.passes[p].defines, [&](const Define& d) {
            return std::find(group.values.begin(), group.values.end(), d.name) != group.values.end() &&
                   std::any_of(options.defines.begin(), options.defines.end(), [&](const Define& c) { return c.name == d.name; });
          });
    if (!check_rule_keywords(plan->passes, plan->pack, plan->scenes, sink)) return nullptr;
    StripRules rules{&plan->pack.constraints, &plan->scenes, &plan->pack.materials};
    auto expansions = expand_and_strip(plan->passes, rules, plan->pack.budget, plan->pack, sink);
    if (!expansions) return nullptr;
    plan->expansions = std::move(*expansions);
    for (size_t p = 0; p < plan->expansions.size(); ++p) {
      PassExpansion& e = plan->expansions[p];
      const std::string& pass = plan->pack.passes[p].name;
      for (const auto& effect : e.strip.constraints) {
        const Constraint& c = *effect.constraint;
        std::string rule = "constraint " + c.keyword;
        if (!c.requires_all.empty()) rule += " requires [" + join_keywords(c.requires_all) + "]";
        if (!c.requires_any.empty()) rule += " requires_any [" + join_keywords(c.requires_any) + "]";
        if (!c.excludes.empty()) rule += " excludes [" + join_keywords(c.excludes) + "]";
        plan->strip.push_back({pass, rule, "-" + effect.removed.text(), c.reason});
      }
      if (!plan->pack.materials.empty() && (e.valid.saturated || e.strip.after_materials.value != e.valid.value))
        plan->strip.push_back({pass, "materials (" + std::to_string(plan->pack.materials.size()) + " presets)",
                               e.valid.text() + " -> " + e.strip.after_materials.text(),
                               "shader_feature combinations no material uses"});
      if (!plan->scenes.empty())
        plan->strip.push_back({pass, "scenes (" + std::to_string(plan->scenes.size()) + ")",
                               e.strip.after_materials.text() + " -> " + e.kept.text(), "keywords no scene enables"});
      if (!plan->usage.empty() &&
          !strip_by_usage(plan->passes[p], pass, e, plan->usage, plan->usage_margin, plan->strip, sink))
        return nullptr;
    }
    for (const PassExpansion& e : plan->expansions) {
      plan->funnel.declared_saturated |= e.declared.saturated;
      plan->funnel.declared += e.declared.value;
      plan->funnel.valid += e.valid.value;
      plan->funnel.kept += e.kept.value;
    }
  }
  return plan;
}

std::vector<ManifestKeywordGroup> Plan::keyword_group_records(uint32_t pass) const {
  StageMask pass_stages = 0;
  for (Stage s : kAllStages)
    if (!entry_point(pass, s).empty()) pass_stages |= stage_bit(s);
  std::vector<ManifestKeywordGroup> records;
  for (const KeywordGroup& group : passes[pass].groups)
    records.push_back({group.pragma, group.values, static_cast<StageMask>(group.stages & pass_stages)});
  return records;
}

}  // namespace kiln
