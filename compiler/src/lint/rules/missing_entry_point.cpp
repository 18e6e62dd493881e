// missing-entry-point: a finding of the build itself, reported under this rule (no check function of its own).
#include "lint/rules/rules.hpp"

namespace kiln::rules {

constinit const LintRule missing_entry_point{
    RuleId::MissingEntryPoint, "MissingEntryPoint", "A stage's entry point does not exist.",
    "The entry point the pack definition names for a stage is not defined in the pass's source (K1402). glslang "
    "only warns about it; kiln treats it as an error.",
    Severity::Error, LintInput::BuildDiagnostic, nullptr, DiagId::MissingEntryPoint};

}  // namespace kiln::rules
