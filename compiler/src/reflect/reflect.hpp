// SPDX-License-Identifier: Apache-2.0
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

// What a pass's binaries disagree on, by Vulkan's rule for one pipeline layout: the descriptor at a (set, binding)
// must have one descriptor type, count, image dimension and arrayness in every stage and variant; names do not
// matter between stages (a stage-per-file pass may call one binding by two names).
//  - SharedSlot (an error): `first` and `second` at one (set, binding) are different descriptors; or, within one
//    stage, two resources of different names (registers of two classes, or a keyword's resource, aliased).
//  - MovedResource (an error): one stage calls one resource by one name at two slots in two variants, which is
//    an automatic binding a keyword moved (the host cannot bind it once for the pass).
//  - MemberMismatch (a warning): one binding's buffer block (or the push-constant blocks) is declared with members
//    that overlap but disagree in offset, size or type; `member` says which. Vulkan allows it; it is a real bug
//    class (one stage reads what another stage's layout wrote as something else).
// Each distinct pair once, in the order first met.
struct LayoutClash {
  enum class Kind { SharedSlot, MovedResource, MemberMismatch } kind = Kind::SharedSlot;
  Resource first, second;  // for push constants: blocks named as the push-constant blocks are, kind uniform_buffer
  bool push_constants = false;
  std::string member;  // MemberMismatch: "'color' (float4, bytes 16-31) and 'tint' (float3, bytes 16-27)"
};

struct MergedLayout {
  PassLayout layout;  // per slot the first resource met; a block's size the largest, its members the union
  std::vector<LayoutClash> clashes;
};

struct LayoutSource {
  Stage stage = Stage::Vertex;
  const Reflection* reflection = nullptr;
};

// Merges the reflections of all binaries of a pass into one layout.
MergedLayout merge_layouts(const std::vector<LayoutSource>& sources);

}  // namespace kiln
