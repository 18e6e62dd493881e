// The rules, one file each; registry.cpp lists them in RuleId order.
#pragma once

#include "lint/rule.hpp"

namespace kiln::rules {

extern const LintRule unused_keyword;
extern const LintRule undeclared_keyword;
extern const LintRule multi_compile_could_be_feature;
extern const LintRule budget_exceeded;
extern const LintRule missing_entry_point;
extern const LintRule interface_mismatch;
extern const LintRule layout_mismatch;
extern const LintRule spirv_invalid;
extern const LintRule fp16_unguarded;
extern const LintRule hlsl_warning;
extern const LintRule build_error;
extern const LintRule block_member_mismatch;

}  // namespace kiln::rules
