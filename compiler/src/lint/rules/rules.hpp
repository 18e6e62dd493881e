// The rules, one file each (rules/<variable>.cpp), declared from their rows in lint/rules.def.
#pragma once

#include "lint/rule.hpp"

namespace kiln::rules {

#define KILN_LINT_RULE(Enumerator, id, variable) extern const LintRule variable;
#include "lint/rules.def"

}  // namespace kiln::rules
