// SPDX-License-Identifier: Apache-2.0
// kiln lint's machinery behind kiln/lint.hpp (the public API): running the rules, and the rule each build
// diagnostic is reported under. Each rule has a stable id (kiln/lint_rule_id.hpp) and lives in rules/<variable>.cpp
// (the build's findings in rules/build_findings.cpp) behind the registry (rule.hpp).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "kiln/build.hpp"
#include "lint/rule.hpp"

namespace kiln {

// Runs the rules that `context` has the input for, by need (sources, plan, built pack), in table order.
void run_lint_rules(const LintContext& context, LintReport& report);
// The rule a build diagnostic is reported under (build-error when no rule claims its id).
RuleId rule_for_diagnostic(DiagId id);

}  // namespace kiln
