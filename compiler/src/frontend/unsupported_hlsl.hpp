// SPDX-License-Identifier: Apache-2.0
// HLSL that glslang 12's front end does not take, recognised in its first error so that the diagnostic names
// the construct and what to write instead. glslang says "'select' : no matching overloaded function found" or
// "'declaration' : Expected"; a user who wrote DXC's HLSL 2021 needs "HLSL 2021 select() is not supported".
// The list is docs/bindings.md's "Other HLSL that glslang 12 does not take"; diag.Cli.UnsupportedHlsl* test it.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace kiln {

struct UnsupportedHlsl {
  std::string construct;  // "HLSL 2021 `select()`"
  std::string advice;     // what to write instead
  int column = 0;         // 1-based column of the construct in the line; 0 when the line does not show it
};

// `message`: glslang's first error ("'select' : no matching overloaded function found"); `line`: the source line
// it points at (empty when unknown).
std::optional<UnsupportedHlsl> recognise_unsupported_hlsl(std::string_view message, std::string_view line);

}  // namespace kiln
