// Stage 7: reflect descriptor sets, bindings, push constants, vertex inputs and block member offsets,
// and check that every variant and stage of a pass agrees on them.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "kiln/diagnostics.hpp"

namespace kiln {

// A module whose layout cannot be reflected truthfully (a block of 4 GiB or more).
struct ReflectionError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// {"resources": [...], "push_constants": [...], "inputs": [...], "outputs": [...]}, sorted, deterministic.
// Throws ReflectionError.
nlohmann::json reflect_spirv(const std::vector<uint32_t>& spirv);

// Two things a pass's binaries disagree on: the resources `first` and `second` at one (set, binding)
// (SharedSlot), one resource name at two slots (MovedResource), or two push constant blocks (PushConstants).
// Each distinct pair once, in the order first met.
struct LayoutClash {
  enum class Kind { SharedSlot, MovedResource, PushConstants } kind = Kind::SharedSlot;
  nlohmann::json first, second;
};

struct MergedLayout {
  nlohmann::json layout;  // {"resources": [...], "push_constants": [...]}
  std::vector<LayoutClash> clashes;
};

// Merges the reflections of all binaries of a pass into one layout.
MergedLayout merge_layouts(const std::vector<const nlohmann::json*>& reflections);

// Whether a binary's reflection holds `resource` (same name, kind, set, binding and shape).
bool holds_resource(const nlohmann::json& reflection, const nlohmann::json& resource);

}  // namespace kiln
