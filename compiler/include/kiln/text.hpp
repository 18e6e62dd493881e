// SPDX-License-Identifier: Apache-2.0
// Small spellings shared by messages: counts with their noun, keyword sets.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace kiln {

// "1 log", "2 logs", "0 logs"; `plural` when the noun does not just take an "s" ("1 pass" needs "passes").
inline std::string counted(uint64_t n, std::string_view singular, std::string_view plural = {}) {
  std::string text = std::to_string(n) + " ";
  if (n == 1) return text.append(singular);
  return plural.empty() ? text.append(singular).append("s") : text.append(plural);
}

// A keyword set as messages show it: "[A B]", and the set with no keyword on as "[<none>]" (as every kiln message
// names that variant), never "[]".
inline std::string keyword_set_text(const std::vector<std::string>& keywords) {
  if (keywords.empty()) return "[<none>]";
  std::string text = "[";
  for (size_t i = 0; i < keywords.size(); ++i) text.append(i ? " " : "").append(keywords[i]);
  return text + "]";
}

}  // namespace kiln
