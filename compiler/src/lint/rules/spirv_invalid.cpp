// spirv-invalid: a finding of the build itself, reported under this rule (no check function of its own).
#include "lint/rules/rules.hpp"

namespace kiln::rules {

constinit const LintRule spirv_invalid{
    RuleId::SpirvInvalid, "SpirvInvalid", "spirv-val rejected a module.",
    "SPIRV-Tools' validator rejected a module after legalization or optimization (K1403), for example a "
    "resource selected at run time, which Vulkan cannot express.",
    Severity::Error, LintInput::BuildDiagnostic, nullptr, DiagId::SpirvInvalid};

}  // namespace kiln::rules
