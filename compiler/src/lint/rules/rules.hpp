// The rules, one file each (rules/<variable>.cpp), declared from their rows in kiln/lint_rules.def.
#pragma once

#include "lint/rule.hpp"

namespace kiln::rules {

#define KILN_LINT_RULE(Enumerator, id, variable) extern const LintRule variable;
#include "kiln/lint_rules.def"

}  // namespace kiln::rules
