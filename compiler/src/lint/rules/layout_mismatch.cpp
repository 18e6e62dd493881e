// layout-mismatch: a finding of the build itself, reported under this rule (no check function of its own).
#include "lint/rules/rules.hpp"

namespace kiln::rules {

constinit const LintRule layout_mismatch{
    RuleId::LayoutMismatch, "LayoutMismatch", "Descriptor layouts differ between variants or stages of a pass.",
    "A binding means different things (type, size, set) in two variants or two stages of one pass, so no single "
    "pipeline layout serves the pass (K1406, from the merged reflection).",
    Severity::Error, LintInput::BuildDiagnostic, nullptr, DiagId::LayoutMismatch};

}  // namespace kiln::rules
