// SPDX-License-Identifier: Apache-2.0
// The tokens of one line of HLSL, as offsets: what lets a column that glslang counted in kiln's preprocessed text
// (re-spaced, comments gone, macros expanded) land on the same token of the file's own line. Words and numbers
// (`1.0f`, `float3`) are one token, a string literal is one, any other character is one; comments are skipped.
#pragma once

#include <cctype>
#include <string_view>
#include <utility>
#include <vector>

namespace kiln {

// Each token's [begin, end) in `line`.
inline std::vector<std::pair<size_t, size_t>> line_tokens(std::string_view line) {
  std::vector<std::pair<size_t, size_t>> out;
  auto word = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; };
  for (size_t i = 0; i < line.size();) {
    const char c = line[i];
    if (std::isspace(static_cast<unsigned char>(c))) {
      ++i;
    } else if (line.substr(i, 2) == "//") {
      break;
    } else if (line.substr(i, 2) == "/*") {
      const size_t end = line.find("*/", i + 2);
      i = end == std::string_view::npos ? line.size() : end + 2;
    } else if (c == '"') {
      size_t end = i + 1;
      while (end < line.size() && line[end] != '"') end += line[end] == '\\' ? 2 : 1;
      end = end < line.size() ? end + 1 : line.size();
      out.emplace_back(i, end);
      i = end;
    } else if (word(c)) {
      size_t end = i + 1;
      while (end < line.size() && (word(line[end]) || line[end] == '.')) ++end;
      out.emplace_back(i, end);
      i = end;
    } else {
      out.emplace_back(i, i + 1);
      ++i;
    }
  }
  return out;
}

}  // namespace kiln
