// SPDX-License-Identifier: Apache-2.0
// The rules whose findings are the build's own diagnostics (LintInput::BuildDiagnostic): `kiln build` and `kiln lint`
// run one check, and lint reports the build's K-number under the rule. They are data only, so they share this file;
// a rule with a check of its own has a file of its own (kiln/lint_rules.def names each rule's file).
#include "lint/rules/rules.hpp"

namespace kiln::rules {

// budget-exceeded
constinit const LintRule budget_exceeded{
    RuleId::BudgetExceeded, "BudgetExceeded", "The pack has more variants than its budget.",
    "After constraints, materials and scenes have stripped what they can, a pass still has more variants than the "
    "pack's \"budget\". The build (K1304) stops before compiling anything.",
    Severity::Error, LintInput::BuildDiagnostic, nullptr, DiagId::BudgetExceeded};

// missing-entry-point
constinit const LintRule missing_entry_point{
    RuleId::MissingEntryPoint, "MissingEntryPoint", "A stage's entry point does not exist.",
    "The entry point the pack definition names for a stage is not defined in the pass's source (K1402). glslang "
    "only warns about it; kiln treats it as an error.",
    Severity::Error, LintInput::BuildDiagnostic, nullptr, DiagId::MissingEntryPoint};

// interface-mismatch
constinit const LintRule interface_mismatch{
    RuleId::InterfaceMismatch, "InterfaceMismatch",
    "A fragment input is not written by the stage before it, or with another type.",
    "For every distinct pair of binaries of the fragment stage and the stage before it (geometry, else domain, else "
    "vertex) that a pass's variants use, each fragment input location must be an output of the same type of the "
    "stage before (from the reflection of both). A mismatch reads undefined values on the GPU, and breaks Vulkan's "
    "rule for the interface between stages. The build's K1410, reported at the fragment input's declaration in the "
    "HLSL, with the stage before's output in a note when the types differ.",
    Severity::Error, LintInput::BuildDiagnostic, nullptr, DiagId::InterfaceMismatch};

// layout-mismatch
constinit const LintRule layout_mismatch{
    RuleId::LayoutMismatch, "LayoutMismatch", "Descriptor layouts differ between variants or stages of a pass.",
    "A binding means different things (type, size, set) in two variants or two stages of one pass, so no single "
    "pipeline layout serves the pass (K1406, from the merged reflection).",
    Severity::Error, LintInput::BuildDiagnostic, nullptr, DiagId::LayoutMismatch};

// spirv-invalid
constinit const LintRule spirv_invalid{
    RuleId::SpirvInvalid, "SpirvInvalid", "spirv-val rejected a module.",
    "SPIRV-Tools' validator rejected a module after legalization or optimization (K1403), for example a "
    "resource selected at run time, which Vulkan cannot express.",
    Severity::Error, LintInput::BuildDiagnostic, nullptr, DiagId::SpirvInvalid};

// hlsl-warning
constinit const LintRule hlsl_warning{
    RuleId::HlslWarning, "HlslWarning", "The HLSL front end warned.",
    "A warning of the HLSL front end (K1407), reported once for all the variants that share it.",
    Severity::Warning, LintInput::BuildDiagnostic, nullptr, DiagId::HlslWarning};

// build-error
constinit const LintRule build_error{
    RuleId::BuildError, "BuildError", "Any other error of the build.",
    "Any other diagnostic of the build (syntax errors, includes, pack definition errors, internal compiler "
    "errors...), with the K-number's message, and a missing or unreadable input. Errors fail the lint; a "
    "warning of the build keeps its severity.",
    Severity::Error, LintInput::BuildDiagnostic, nullptr, std::nullopt};

// block-member-mismatch
constinit const LintRule block_member_mismatch{
    RuleId::BlockMemberMismatch, "BlockMemberMismatch",
    "One binding's buffer block is declared with members that overlap but disagree.",
    "Two stages or variants of a pass declare the block at one (set, binding), or their push-constant blocks, with "
    "members that share bytes but differ in offset, size or type (names may differ). Vulkan accepts it, and a block "
    "with fewer members in one stage is fine; but one declaration then reads as one type what another writes as "
    "another. The build's K1411, a warning, at the first declaration.",
    Severity::Warning, LintInput::BuildDiagnostic, nullptr, DiagId::BlockMemberMismatch};

}  // namespace kiln::rules
