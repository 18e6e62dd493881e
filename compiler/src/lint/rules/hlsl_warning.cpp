// hlsl-warning: a finding of the build itself, reported under this rule (no check function of its own).
#include "lint/rules/rules.hpp"

namespace kiln::rules {

constinit const LintRule hlsl_warning{
    RuleId::HlslWarning, "HlslWarning", "The HLSL front end warned.",
    "A warning of the HLSL front end (K1407), reported once for all the variants that share it.",
    Severity::Warning, LintInput::BuildDiagnostic, nullptr, DiagId::HlslWarning};

}  // namespace kiln::rules
