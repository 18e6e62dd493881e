// Stage 7: reflect descriptor sets, bindings, push constants, vertex inputs and block member offsets,
// and check that every variant and stage of a pass agrees on them.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "kiln/diagnostics.hpp"
#include "kiln/manifest_json.hpp"

namespace kiln {

// A module whose layout cannot be reflected truthfully (a block of 4 GiB or more).
struct ReflectionError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Resources, push constants, inputs and outputs, sorted, deterministic (the targets' binding records are the
// cross stage's). Throws ReflectionError.
Reflection reflect_spirv(const std::vector<uint32_t>& spirv);

// Two things a pass's binaries disagree on: the resources `first` and `second` at one (set, binding)
// (SharedSlot), one resource name at two slots (MovedResource), or two push constant blocks (PushConstants).
// Each distinct pair once, in the order first met.
struct LayoutClash {
  enum class Kind { SharedSlot, MovedResource, PushConstants } kind = Kind::SharedSlot;
  // The resources (SharedSlot, MovedResource), or each side's first push constant block (PushConstants).
  Resource first, second;
};

struct MergedLayout {
  PassLayout layout;
  std::vector<LayoutClash> clashes;
};

// Merges the reflections of all binaries of a pass into one layout.
MergedLayout merge_layouts(const std::vector<const Reflection*>& reflections);

}  // namespace kiln
