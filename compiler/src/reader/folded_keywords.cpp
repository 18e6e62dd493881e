// SPDX-License-Identifier: Apache-2.0
// Where each folded keyword of a pass lives (kiln/folded_keywords.hpp): derived from the pass's groups alone, so that
// the compiler that declares the constants and the readers that set them agree by construction.
#include "kiln/folded_keywords.hpp"

#include <algorithm>

namespace kiln {

std::vector<FoldedKeyword> folded_keywords(const std::vector<ManifestKeywordGroup>& groups) {
  std::vector<FoldedKeyword> out;
  uint32_t next_constant = kKeywordConstantIdBase, next_offset = 0;
  for (const ManifestKeywordGroup& group : groups) {
    const KeywordKind kind = keyword_kind(group.pragma);
    if (!is_folded(kind)) continue;
    if (kind == KeywordKind::SpecializationInteger) {
      const auto off = std::find(group.values.begin(), group.values.end(), std::string());
      const uint32_t fallback = off == group.values.end() ? 0 : static_cast<uint32_t>(off - group.values.begin());
      for (uint32_t place = 0; place < group.values.size(); ++place)
        out.push_back(FoldedKeyword{group.values[place], kind, group.stages, next_constant, place, fallback});
      ++next_constant;
      continue;
    }
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
