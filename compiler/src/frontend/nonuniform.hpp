// SPDX-License-Identifier: Apache-2.0
// NonUniformResourceIndex, which glslang 12's HLSL does not have (DXC: the index and the resource access it selects
// are decorated NonUniform, and the module declares the capabilities). kiln's front end keeps DXC's meaning in two
// steps (docs/bindings.md):
//  1. before the parse, `NonUniformResourceIndex(` becomes a call of a marker function of the same length
//     (columns stay the user's), defined in the preamble (lines stay the user's): rewrite_nonuniform_index;
//  2. on glslang's SPIR-V, decorate_nonuniform replaces each marker call by the value it passes on, follows that
//     value (through arithmetic, local variables and function parameters) to the resource accesses it selects,
//     decorates them NonUniform (access chains into descriptors, the descriptors loaded through them, sampled
//     images and images made from them), declares ShaderNonUniform and each array kind's non-uniform indexing
//     capability with SPV_EXT_descriptor_indexing, and removes the marker function.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace kiln {

inline constexpr std::string_view kNonUniformMarker = "kiln_NonUniformResIndex";  // as long as NonUniformResourceIndex
// The marker's definition, for the preamble (glslang's string -1: no line of the user's file moves).
inline constexpr std::string_view kNonUniformMarkerDefinition = "uint kiln_NonUniformResIndex(uint i) { return i; }\n";

// The text with each call of NonUniformResourceIndex renamed to the marker; nothing when it has none (or declares
// a function of that name itself).
std::optional<std::string> rewrite_nonuniform_index(std::string_view text);

// Step 2 on a module glslang made from a rewritten text. Returns how many ids it decorated.
size_t decorate_nonuniform(std::vector<uint32_t>& spirv);

}  // namespace kiln
