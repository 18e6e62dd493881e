// SPDX-License-Identifier: Apache-2.0
// Shader stages and output targets: the enumerations the compiler, the pack manifest and the runtime reader
// share, with the names and file extensions they go by. Header-only, so that the runtime reader links none
// of the compiler. What each target's back end does is in compiler/src/cross/targets.hpp.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace kiln {

// Every stage glslang's HLSL front end compiles. Hull and domain are HLSL's names for tessellation control and
// evaluation. New stages go at the end: a stage's value indexes per-stage arrays.
enum class Stage : uint8_t { Vertex, Fragment, Compute, Geometry, Hull, Domain };
inline constexpr int kStageCount = 6;
inline constexpr std::array<Stage, kStageCount> kAllStages{Stage::Vertex, Stage::Fragment, Stage::Compute,
                                                          Stage::Geometry, Stage::Hull, Stage::Domain};
using StageMask = uint8_t;
inline constexpr StageMask stage_bit(Stage s) { return static_cast<StageMask>(1u << static_cast<unsigned>(s)); }
inline constexpr StageMask kAllStageBits = 0x3F;

struct StageName {
  Stage stage;
  std::string_view name;        // in pack definitions, the manifest, `kiln list`
  std::string_view short_name;  // glslangValidator's -S, file suffixes (.vert.hlsl)
};
inline constexpr std::array<StageName, kStageCount> kStageNames{{
    {Stage::Vertex, "vertex", "vert"},
    {Stage::Fragment, "fragment", "frag"},
    {Stage::Compute, "compute", "comp"},
    {Stage::Geometry, "geometry", "geom"},
    {Stage::Hull, "hull", "tesc"},
    {Stage::Domain, "domain", "tese"},
}};

constexpr std::string_view stage_name(Stage stage) { return kStageNames[static_cast<size_t>(stage)].name; }
constexpr std::string_view stage_short_name(Stage stage) { return kStageNames[static_cast<size_t>(stage)].short_name; }
constexpr std::optional<Stage> parse_stage(std::string_view name) {
  for (const StageName& s : kStageNames)
    if (s.name == name) return s.stage;
  return std::nullopt;
}

// The output targets, generated from kiln/targets.def (one row per target): a target's index is its value.
enum class Target : uint8_t {
#define KILN_TARGET(Enumerator, ...) Enumerator,
#include "kiln/targets.def"
};

struct TargetName {
  Target target;
  std::string_view name;              // in pack definitions, `--target`, the manifest's blob records
  std::string_view extension;         // of `--emit` files and `kiln extract` outputs
  std::string_view other_extensions;  // further output extensions `kiln compile` takes, space-separated
  std::string_view emit;              // the `--emit` stage that dumps it
  bool cross_compiled;                // by a SPIRV-Cross back end (cross/targets.hpp); SPIR-V is not
};
inline constexpr auto kTargetNames = std::to_array<TargetName>({
#define KILN_TARGET(Enumerator, id, extension, other_extensions, C_NAME, emit, library, description) \
  {Target::Enumerator, #id, extension, other_extensions, emit, false},
#define KILN_CROSS_TARGET(Enumerator, id, extension, other_extensions, C_NAME, emit, library, description) \
  {Target::Enumerator, #id, extension, other_extensions, emit, true},
#include "kiln/targets.def"
});
inline constexpr int kTargetCount = static_cast<int>(kTargetNames.size());

constexpr std::string_view target_name(Target target) { return kTargetNames[static_cast<size_t>(target)].name; }
constexpr std::string_view target_extension(Target target) { return kTargetNames[static_cast<size_t>(target)].extension; }
constexpr std::optional<Target> parse_target(std::string_view name) {
  for (const TargetName& t : kTargetNames)
    if (t.name == name) return t.target;
  return std::nullopt;
}

// "spirv, glsl, gles or msl", for messages.
inline std::string target_name_list() {
  std::string out;
  for (size_t i = 0; i < kTargetNames.size(); ++i)
    out += (i == 0 ? "" : i + 1 == kTargetNames.size() ? " or " : ", ") + std::string(kTargetNames[i].name);
  return out;
}

static_assert([] {
  for (size_t i = 0; i < kStageNames.size(); ++i)
    if (static_cast<size_t>(kStageNames[i].stage) != i) return false;
  return true;
}(), "kStageNames is indexed by Stage");
static_assert([] {
  for (size_t i = 0; i < kTargetNames.size(); ++i)
    if (static_cast<size_t>(kTargetNames[i].target) != i) return false;
  return true;
}(), "kTargetNames is indexed by Target");

}  // namespace kiln
