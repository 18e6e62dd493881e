// build-error: a finding of the build itself, reported under this rule (no check function of its own).
#include "lint/rules/rules.hpp"

namespace kiln::rules {

constinit const LintRule build_error{
    RuleId::BuildError, "BuildError", "Any other error of the build.",
    "Any other diagnostic of the build (syntax errors, includes, pack definition errors, internal compiler "
    "errors...), with the K-number's message, and a missing or unreadable input. Errors fail the lint; a "
    "warning of the build keeps its severity.",
    Severity::Error, LintInput::BuildDiagnostic, nullptr, std::nullopt};

}  // namespace kiln::rules
