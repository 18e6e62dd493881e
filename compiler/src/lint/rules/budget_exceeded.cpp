// budget-exceeded: a finding of the build itself, reported under this rule (no check function of its own).
#include "lint/rules/rules.hpp"

namespace kiln::rules {

constinit const LintRule budget_exceeded{
    RuleId::BudgetExceeded, "BudgetExceeded", "The pack has more variants than its budget.",
    "After constraints, materials and scenes have stripped what they can, a pass still has more variants than the "
    "pack's \"budget\". The build (K1304) stops before compiling anything.",
    Severity::Error, LintInput::BuildDiagnostic, nullptr, DiagId::BudgetExceeded};

}  // namespace kiln::rules
