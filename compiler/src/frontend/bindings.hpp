// SPDX-License-Identifier: Apache-2.0
// The binding model of docs/bindings.md, the part every front end shares: finding the resources whose
// binding the source states with [[vk::binding(b, s)]], which no shift may move.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <utility>

namespace kiln {

// Declared name -> (binding, set) of every declaration with a [[vk::binding]] attribute in preprocessed
// HLSL. A cbuffer is named by its block name, anything else by its variable name.
std::map<std::string, std::pair<uint32_t, uint32_t>> find_vk_bindings(std::string_view preprocessed);

}  // namespace kiln
