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

enum class Stage : uint8_t { Vertex, Fragment };
inline constexpr int kStageCount = 2;
inline constexpr std::array<Stage, kStageCount> kAllStages{Stage::Vertex, Stage::Fragment};
using StageMask = uint8_t;
inline constexpr StageMask stage_bit(Stage s) { return static_cast<StageMask>(1u << static_cast<unsigned>(s)); }
inline constexpr StageMask kAllStageBits = 0x3;

constexpr std::string_view stage_name(Stage stage) { return stage == Stage::Vertex ? "vertex" : "fragment"; }
constexpr std::optional<Stage> parse_stage(std::string_view name) {
  for (Stage s : kAllStages)
    if (stage_name(s) == name) return s;
  return std::nullopt;
}

// In the order of the table below: a target's index is its value.
enum class Target : uint8_t { Spirv, Glsl, Gles, Msl };

struct TargetName {
  Target target;
  std::string_view name;       // in pack definitions, `--target`, the manifest's blob records
  std::string_view extension;  // of `--emit` files and `kiln extract` outputs
};
inline constexpr std::array<TargetName, 4> kTargetNames{{
    {Target::Spirv, "spirv", ".spv"},
    {Target::Glsl, "glsl", ".glsl"},
    {Target::Gles, "gles", ".es.glsl"},
    {Target::Msl, "msl", ".metal"},
}};
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
  for (size_t i = 0; i < kTargetNames.size(); ++i)
    if (static_cast<size_t>(kTargetNames[i].target) != i) return false;
  return true;
}(), "kTargetNames is indexed by Target");

}  // namespace kiln
