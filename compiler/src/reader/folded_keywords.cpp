// Where each folded keyword of a pass lives (kiln/folded_keywords.hpp): derived from the pass's groups alone, so that
// the compiler that declares the constants and the readers that set them agree by construction.
#include "kiln/folded_keywords.hpp"

namespace kiln {

std::string_view keyword_kind_name(KeywordKind kind) {
  switch (kind) {
    case KeywordKind::Variant: return "variant";
    case KeywordKind::DynamicBranch: return kDynamicBranchPragma;
    case KeywordKind::SpecializationConstant: return kSpecializationConstantPragma;
  }
  return "variant";
}

std::vector<FoldedKeyword> folded_keywords(const std::vector<ManifestKeywordGroup>& groups) {
  std::vector<FoldedKeyword> out;
  uint32_t next_constant = kKeywordConstantIdBase, next_offset = 0;
  for (const ManifestKeywordGroup& group : groups) {
    const KeywordKind kind = keyword_kind(group.pragma);
    if (!is_folded(kind)) continue;
    for (const std::string& value : group.values) {
      if (value.empty()) continue;
      uint32_t& next = kind == KeywordKind::SpecializationConstant ? next_constant : next_offset;
      out.push_back(FoldedKeyword{value, kind, group.stages, next});
      next += kind == KeywordKind::SpecializationConstant ? 1 : 4;
    }
  }
  return out;
}

}  // namespace kiln
