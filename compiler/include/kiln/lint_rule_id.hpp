// SPDX-License-Identifier: Apache-2.0
// The stable ids of kiln lint's rules, generated from kiln/lint_rules.def (one row per rule). Code names a rule by RuleId, so
// a misspelt rule is a compile error; the id text (`unused-keyword`) is what users see, in text, JSON and SARIF, and
// the anchor of its section in docs/lint.md. Never rename an id: CI configurations and SARIF baselines refer to it.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string_view>

namespace kiln {

enum class RuleId : unsigned char {
#define KILN_LINT_RULE(Enumerator, id, variable, file) Enumerator,
#include "kiln/lint_rules.def"
};

// Indexed by RuleId; the order is the rule table's (and SARIF's tool.driver.rules).
inline constexpr auto kRuleIdTexts = std::to_array<std::string_view>({
#define KILN_LINT_RULE(Enumerator, id, variable, file) id,
#include "kiln/lint_rules.def"
});
inline constexpr size_t kRuleCount = kRuleIdTexts.size();

constexpr std::string_view rule_id_text(RuleId id) { return kRuleIdTexts[static_cast<size_t>(id)]; }

constexpr std::optional<RuleId> parse_rule_id(std::string_view text) {
  for (size_t i = 0; i < kRuleCount; ++i)
    if (kRuleIdTexts[i] == text) return static_cast<RuleId>(i);
  return std::nullopt;
}

// Ids are lower-case words joined by '-', and unique: checked when kiln compiles.
constexpr bool rule_ids_are_well_formed() {
  for (size_t i = 0; i < kRuleCount; ++i) {
    std::string_view id = kRuleIdTexts[i];
    if (id.empty() || id.front() == '-' || id.back() == '-') return false;
    for (char c : id)
      if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-')) return false;
    for (size_t j = 0; j < i; ++j)
      if (kRuleIdTexts[j] == id) return false;
  }
  return true;
}
static_assert(rule_ids_are_well_formed(), "lint rule ids must be unique lower-case words joined by '-'");
static_assert(parse_rule_id(rule_id_text(RuleId::BuildError)) == RuleId::BuildError);

}  // namespace kiln
