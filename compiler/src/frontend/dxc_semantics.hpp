// SPDX-License-Identifier: Apache-2.0
// Interfaces glslang 12 builds differently from DXC without a word, put back to DXC's on glslang's SPIR-V
// (docs/bindings.md, "HLSL that glslang 12 reads differently"):
//  - an unbounded resource array (`Texture2D textures[] : register(t0, space1)`) is a runtime descriptor array in
//    DXC; glslang sizes it by the largest constant index it sees (1 when it is indexed dynamically), so the host's
//    descriptor count and every index past it were wrong;
//  - `SV_ViewID` and `SV_ShadingRate` are the ViewIndex and ShadingRateKHR built-ins in DXC (PrimitiveShadingRateKHR
//    for an output); glslang makes them user inputs with locations, which moves every later location.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "frontend/hlsl_compat.hpp"
#include "kiln/result.hpp"

namespace kiln {

// The names of the resource arrays the text declares unbounded at file scope (`T name[]`), in order.
std::vector<std::string> unbounded_resource_arrays(std::string_view text);

// Whether the text names SV_ViewID or SV_ShadingRate (semantics are case-insensitive): the front end then asks
// glslang for the semantics in the SPIR-V (its hlsl_functionality1 decorations), which restore_builtin_semantics
// reads and removes.
bool names_builtin_semantics(std::string_view text);

// The (name, location) of every declaration the text gives a `[[vk::location(N)]]`, sorted: a parameter's or a
// struct member's name.
std::vector<std::pair<std::string, uint32_t>> explicit_locations(std::string_view text);

// The edits on glslang's module. They fail when the module cannot be edited as it should (never expected of
// glslang's output). restore_builtin_semantics moves the locations glslang numbered after a built-in down, and
// leaves those in `located` (explicit_locations) where the author put them.
Result<void> make_arrays_unbounded(std::vector<uint32_t>& spirv, const std::vector<std::string>& names);
Result<void> restore_builtin_semantics(std::vector<uint32_t>& spirv, const std::vector<std::pair<std::string, uint32_t>>& located);

// `[[vk::offset(N)]]` (strip_member_offsets) written into the Offset decorations of the members it names, in every
// laid-out struct of that name. A stated offset equal to HLSL's packing needs nothing; a later one moves the member
// and those after it by the difference, when that is a multiple of 16 bytes (every member keeps its alignment) and
// no array holds the struct (its stride would change). The rest are not honoured: for each, its index in `stated`
// and why.
// The names rewrite_reserved_names gave (`kiln_reserved_texture`) made the author's again (`texture`) in the
// module's OpName and OpMemberName.
void restore_reserved_names(std::vector<uint32_t>& spirv);

// The first location two of the entry point's inputs (or outputs) share in the same component, as spirv-val's
// words ("conflicting input location assignment at location N"), for locate_location_conflict
// (module_limits.hpp); nothing when there is none.
std::optional<std::string> conflicting_location(const std::vector<uint32_t>& spirv);

struct UnhonouredOffset {
  size_t stated = 0;
  std::string reason;
};
std::vector<UnhonouredOffset> write_member_offsets(std::vector<uint32_t>& spirv, const std::vector<StatedOffset>& stated);

}  // namespace kiln
