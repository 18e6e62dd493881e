// unused-keyword: a declared keyword whose variants are identical to the ones without it.
#include <algorithm>
#include <iterator>
#include <map>

#include "lint/rules/rules.hpp"

namespace kiln::rules {
namespace {

// Every keyword changes some compiled code: compare variants that differ only in that keyword.
void check_unused_keyword(const LintContext& context, LintReport& report) {
  const PlanListing& plan = *context.plan;
  const PackView& pack = *context.pack;
  for (size_t p = 0; p < pack.passes.size() && p < plan.pass_groups.size(); ++p) {
    const std::vector<PackView::Variant>& variants = pack.passes[p].variants;
    std::map<std::vector<std::string>, size_t> by_keywords;
    for (size_t i = 0; i < variants.size(); ++i) by_keywords[variants[i].keywords] = i;
    for (const KeywordGroup& group : plan.pass_groups[p].second) {
      for (const std::string& keyword : group.values) {
        if (keyword.empty()) continue;
        bool compared = false, changes = false;
        for (const auto& [keywords, index] : by_keywords) {
          if (std::find(keywords.begin(), keywords.end(), keyword) == keywords.end()) continue;
          std::vector<std::string> without;
          std::copy_if(keywords.begin(), keywords.end(), std::back_inserter(without), [&](const std::string& k) { return k != keyword; });
          auto other = by_keywords.find(without);
          if (other == by_keywords.end()) continue;
          compared = true;
          if (variants[index].binaries != variants[other->second].binaries) {
            changes = true;
            break;
          }
        }
        if (compared && !changes)
          add_finding(report, RuleId::UnusedKeyword, group.declared_at,
                      "keyword '" + keyword + "' changes no compiled code of pass '" + plan.pass_groups[p].first +
                          "': every variant with it is identical to the one without",
                      {"remove it, or use it under #if defined(" + keyword + ")"});
      }
    }
  }
}

}  // namespace

constinit const LintRule unused_keyword{
    RuleId::UnusedKeyword, "UnusedKeyword", "A declared keyword changes no stage's compiled code.",
    "A keyword declared by a #pragma multi_compile or shader_feature doubles (or more) the variants of its pass. "
    "This rule compares the built variants that differ only in that keyword: when every pair compiled to the same "
    "binaries for every stage, the keyword changes nothing and only costs build time and pack size.",
    Severity::Warning, LintInput::BuiltPack, check_unused_keyword};

}  // namespace kiln::rules
