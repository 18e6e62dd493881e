// SPDX-License-Identifier: Apache-2.0
// The rules, declared from their rows in kiln/lint_rules.def: a rule with a check in rules/<variable>.cpp, the build's
// findings in rules/build_findings.cpp.
#pragma once

#include "lint/rule.hpp"

namespace kiln::rules {

#define KILN_LINT_RULE(Enumerator, id, variable, file) extern const LintRule variable;
#include "kiln/lint_rules.def"

}  // namespace kiln::rules
