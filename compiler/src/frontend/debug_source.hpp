// SPDX-License-Identifier: Apache-2.0
// -g modules keep the files as written (what DXC -Zi and glslangValidator -g keep), not the text kiln
// preprocessed: glslang, given kiln's collapsed preprocessed text, put that text in OpSource. A debugger (RenderDoc,
// Nsight) shows OpSource's text at OpLine's lines; the #line directives of the preprocessed text already make
// those lines the files' own.
#pragma once

#include <cstdint>
#include <vector>

#include "frontend/frontend.hpp"

namespace kiln {

// Replaces the module's OpSource and OpSourceContinued with one OpSource per file (its OpString name, its text,
// continued past an instruction's word limit), the entry first, in glslang's language and version. Nothing
// changes when `sources` is empty or the module has no OpSource.
void keep_original_sources(std::vector<uint32_t>& spirv, const std::vector<SourceText>& sources);

}  // namespace kiln
