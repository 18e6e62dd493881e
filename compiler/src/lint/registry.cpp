// SPDX-License-Identifier: Apache-2.0
// The rule table: every rule kiln lint has, in RuleId order, from kiln/lint_rules.def. A new rule is a file in rules/
// and a row there.
#include <array>
#include <cstdlib>
#include <sstream>

#include "lint/rules/rules.hpp"

namespace kiln {
namespace {

using namespace rules;

const std::array<const LintRule*, kRuleCount> kRules{
#define KILN_LINT_RULE(Enumerator, id, variable, file) &variable,
#include "kiln/lint_rules.def"
};

// The array's size is checked by the compiler; its order is checked once, here, and by unit.LintRules.
bool table_is_in_rule_id_order() {
  for (size_t i = 0; i < kRules.size(); ++i)
    if (static_cast<size_t>(kRules[i]->id) != i) return false;
  return true;
}

}  // namespace

std::span<const LintRule* const> lint_rules() {
  static const bool ordered = table_is_in_rule_id_order();
  if (!ordered) std::abort();  // a programming error in this file, caught by every lint test
  return kRules;
}

const LintRule& lint_rule(RuleId id) { return *lint_rules()[static_cast<size_t>(id)]; }

void add_finding(LintReport& report, RuleId rule, SourceLocation at, std::string message, std::vector<std::string> notes) {
  report.findings.push_back({rule, lint_rule(rule).severity, std::move(at), std::move(message), std::move(notes)});
}

std::vector<std::string> raw_lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

SourceLocation LintContext::pass_location(const std::string& name) const {
  if (plan)
    for (size_t p = 0; p < plan->pass_groups.size() && p < plan->pass_locations.size(); ++p)
      if (plan->pass_groups[p].first == name) return plan->pass_locations[p];
  return SourceLocation{pack_file, 0, 0};
}

}  // namespace kiln
