// SPDX-License-Identifier: Apache-2.0
// A pass of kiln's own in the combine-image-samplers step (spirv_tools.hpp): a texture array and one sampler that
// share a (set, binding) become one array of combined image samplers, which SPIRV-Tools' convert-to-sampled-image
// pass refuses (it takes single textures only).
#pragma once

#include <cstdint>
#include <set>
#include <utility>
#include <vector>

#include "kiln/result.hpp"

namespace kiln {

// The module with every such pair combined, and the (set, binding) of each.
struct CombinedTextureArrays {
  std::vector<uint32_t> spirv;
  std::set<std::pair<uint32_t, uint32_t>> slots;
};

// `Texture2D textures[4] : register(t0); SamplerState s : register(s0);` under combined image samplers: the
// array's variable becomes a `sampler2D textures[4]` (what C++ code binds at that binding), each `textures[i]`
// sampled with `s` loads element i of it, and any other use of an element (Load, GetDimensions) takes the
// element's image (OpImage); the sampler is left loaded but unused, for the caller's dead-code passes. NonUniform
// decorations stay on the loads they were on. Slots with a single texture, or more than one texture or sampler, are
// left to SPIRV-Tools. Refused, with a message in glslang's `'name' : why` shape (the driver locates the name's
// declaration): the sampler also samples another texture, the array is also sampled with another sampler, the
// sampler is an array, or the array is used other than one element at a time.
Result<CombinedTextureArrays> combine_texture_arrays(const std::vector<uint32_t>& spirv);

}  // namespace kiln
