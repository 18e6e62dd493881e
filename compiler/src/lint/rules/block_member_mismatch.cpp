// block-member-mismatch: a finding of the build itself (K1411, layouts/layout_check.cpp), reported under this rule.
#include "lint/rules/rules.hpp"

namespace kiln::rules {

constinit const LintRule block_member_mismatch{
    RuleId::BlockMemberMismatch, "BlockMemberMismatch",
    "One binding's buffer block is declared with members that overlap but disagree.",
    "Two stages or variants of a pass declare the block at one (set, binding), or their push-constant blocks, with "
    "members that share bytes but differ in offset, size or type (names may differ). Vulkan accepts it, and a block "
    "with fewer members in one stage is fine; but one declaration then reads as one type what another writes as "
    "another. The build's K1411, a warning, at the first declaration.",
    Severity::Warning, LintInput::BuildDiagnostic, nullptr, DiagId::BlockMemberMismatch};

}  // namespace kiln::rules
