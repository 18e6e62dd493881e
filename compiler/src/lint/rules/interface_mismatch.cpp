// interface-mismatch: a finding of the build itself (K1410, layouts/interface_check.cpp), reported under this rule:
// `kiln build` and `kiln lint` run one check.
#include "lint/rules/rules.hpp"

namespace kiln::rules {

constinit const LintRule interface_mismatch{
    RuleId::InterfaceMismatch, "InterfaceMismatch",
    "A fragment input is not written by the stage before it, or with another type.",
    "For every distinct pair of binaries of the fragment stage and the stage before it (geometry, else domain, else "
    "vertex) that a pass's variants use, each fragment input location must be an output of the same type of the "
    "stage before (from the reflection of both). A mismatch reads undefined values on the GPU, and breaks Vulkan's "
    "rule for the interface between stages. The build's K1410, reported at the fragment input's declaration in the "
    "HLSL, with the stage before's output in a note when the types differ.",
    Severity::Error, LintInput::BuildDiagnostic, nullptr, DiagId::InterfaceMismatch};

}  // namespace kiln::rules
