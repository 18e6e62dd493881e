// SPDX-License-Identifier: Apache-2.0
// multi-compile-could-be-feature: a multi_compile group no scene profile varies.
#include <set>

#include "lint/rules/rules.hpp"

namespace kiln::rules {
namespace {

void check_multi_compile_could_be_feature(const LintContext& context, LintReport& report) {
  const PlanListing& plan = *context.plan;
  if (plan.scenes.empty()) return;
  for (const auto& [pass, groups] : plan.pass_groups) {
    for (const KeywordGroup& group : groups) {
      if (group.material_feature || is_folded(group.kind())) continue;  // a folded group multiplies no modules
      bool varied = false;
      for (const auto& [scene, keywords] : plan.scenes)
        for (const std::string& value : group.values)
          if (!value.empty() && keywords.count(value)) varied = true;
      if (!varied)
        add_finding(report, RuleId::MultiCompileCouldBeFeature, group.declared_at,
                    "no scene enables any keyword of '#pragma " + group.pragma + "' (pass '" + pass +
                        "'): declare it with shader_feature so that only materials that use it pay for it, or remove it");
    }
  }
}

}  // namespace

constinit const LintRule multi_compile_could_be_feature{
    RuleId::MultiCompileCouldBeFeature, "MultiCompileCouldBeFeature",
    "No scene varies a multi_compile group: shader_feature would strip it.",
    "Every variant of a multi_compile group is built whatever the materials use. When none of the scene profiles "
    "given with --scene enables any keyword of the group, declaring it with shader_feature lets the build strip "
    "it unless a material uses it. Runs only when scenes are given.",
    Severity::Warning, LintInput::Plan, check_multi_compile_could_be_feature};

}  // namespace kiln::rules
