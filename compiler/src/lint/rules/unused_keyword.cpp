// SPDX-License-Identifier: Apache-2.0
// unused-keyword: a declared keyword whose variants are identical to the ones without it.
#include <algorithm>
#include <iterator>
#include <map>
#include <regex>
#include <set>

#include "declarations/declarations.hpp"
#include "lint/rules/rules.hpp"

namespace kiln::rules {
namespace {

// The names the sources use, apart: in directives (#if defined(KILN_FOLDED_K)) and in code (`if (K)`).
struct NamesUsed {
  std::set<std::string> in_directives, in_code;
};

NamesUsed names_used(const LintContext& context) {
  static const std::regex name_re(R"([A-Za-z_][A-Za-z0-9_]*)");
  static const std::regex directive_re(R"(^\s*#)");
  static const std::regex pragma_re(R"(^\s*#\s*pragma\b)");
  NamesUsed used;
  for (const auto& [path, text] : context.sources)
    for (const std::string& line : code_lines(text)) {
      if (std::regex_search(line, pragma_re)) continue;  // a declaration is no use
      std::set<std::string>& names = std::regex_search(line, directive_re) ? used.in_directives : used.in_code;
      for (auto it = std::sregex_iterator(line.begin(), line.end(), name_re); it != std::sregex_iterator(); ++it) names.insert(it->str());
    }
  return used;
}

// A folded group is one module for all its values (docs/keywords.md): its variants are identical by design. What
// makes its keywords do something is code that tests them as values, `if (K)` (KILN_FOLDED_K says K is a bool,
// KILN_GROUP_OF_K names a specialization_constant_int group's int). A group whose keywords are only tested by #if
// changes nothing folded: `defined(K)` holds for every value.
void check_folded_group(const PlanListing& plan, size_t p, const KeywordGroup& group, const NamesUsed& used, LintReport& report) {
  for (const std::string& keyword : group.values)
    if (!keyword.empty() && (used.in_code.count(keyword) || used.in_directives.count("KILN_FOLDED_" + keyword) ||
                             used.in_directives.count("KILN_GROUP_OF_" + keyword) || used.in_code.count("KILN_GROUP_OF_" + keyword)))
      return;
  for (const std::string& keyword : group.values) {
    if (keyword.empty()) continue;
    add_finding(report, RuleId::UnusedKeyword, group.declared_at,
                "folded keyword '" + keyword + "' (" + std::string(keyword_kind_name(group.kind())) + ") of pass '" +
                    plan.pass_groups[p].first + "' is tested by no code as a value: its one module is the same for every value",
                {"test it with `if (" + keyword + ")` under `#if defined(KILN_FOLDED_" + keyword +
                 ")` (docs/keywords.md); `#if defined(" + keyword + ")` holds for every value of a folded group"});
  }
}

// Every keyword changes some compiled code: compare variants that differ only in that keyword.
void check_unused_keyword(const LintContext& context, LintReport& report) {
  const PlanListing& plan = *context.plan;
  const PackView& pack = *context.pack;
  std::optional<NamesUsed> used;  // read once, for the first folded group
  for (size_t p = 0; p < pack.passes.size() && p < plan.pass_groups.size(); ++p) {
    const std::vector<PackView::Variant>& variants = pack.passes[p].variants;
    std::map<std::vector<std::string>, size_t> by_keywords;
    for (size_t i = 0; i < variants.size(); ++i) by_keywords[variants[i].keywords] = i;
    for (const KeywordGroup& group : plan.pass_groups[p].second) {
      if (is_folded(group.kind())) {
        if (!used) used = names_used(context);
        check_folded_group(plan, p, group, *used, report);
        continue;
      }
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
    "binaries for every stage, the keyword changes nothing and only costs build time and pack size. A folded group "
    "(dynamic_branch, specialization_constant, specialization_constant_int) is one module by design: its keywords "
    "are reported only when no code tests them as values (if (K), KILN_FOLDED_K, KILN_GROUP_OF_K).",
    Severity::Warning, LintInput::BuiltPack, check_unused_keyword};

}  // namespace kiln::rules
