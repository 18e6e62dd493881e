// SPDX-License-Identifier: Apache-2.0
// The functions an HLSL file defines, with their lines: the function records of a coverage tracefile (lcov's FN
// and FNDA). The instrumented modules cannot say where a function starts and ends, because the optimizer inlined
// every call before the probes went in; the source can. A scan, not a parser: it skips comments, strings and
// preprocessor lines, and takes every `type name(...) [: SEMANTIC] { ... }` at file, namespace or struct scope
// as a function, from the line of its name to the line of its closing brace. Both arms of an `#if` are scanned,
// so a function defined twice (once per precision, say) gives two records of one name.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace kiln::render {

struct HlslFunction {
  std::string name;     // "D_GGX"; a struct's member function "Surface::albedo"
  uint32_t first_line;  // 1-based: the line of the name
  uint32_t last_line;   // the line of the closing brace
};

// In the order of their first lines. Text that does not scan (an unbalanced brace) gives the functions found
// before it.
std::vector<HlslFunction> hlsl_functions(std::string_view text);

}  // namespace kiln::render
