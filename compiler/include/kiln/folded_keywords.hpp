// Folded keywords (docs/keywords.md): keyword groups that do not multiply modules. A `multi_compile` or
// `shader_feature` group builds one module per value; a `dynamic_branch`, `specialization_constant` or
// `specialization_constant_int` group builds one module for all its values, in which each keyword is a bool the
// shader tests with `if`:
//   * specialization_constant: `[[vk::constant_id(id)]] const bool KEYWORD = false;`, set when the pipeline is
//     made (VkSpecializationInfo; GLSL and GLSL ES: `#define SPIRV_CROSS_CONSTANT_ID_<id>` before compiling; MSL:
//     the function constant of that index);
//   * specialization_constant_int: one int specialization constant for the whole group,
//     `[[vk::constant_id(id)]] const int _KilnGroup<id> = <the off value's place, or 0>;`, whose value is the place
//     of the group's chosen value (0, 1, ... in declaration order, the off value `_` counted); each keyword K is
//     `(_KilnGroup<id> == place)` and KILN_GROUP_OF_K names the int, for a `switch`;
//   * dynamic_branch (Unity's): a member of the uniform block `_KilnKeywords` (set 0, binding 62), 4 bytes, 0 or 1,
//     set before the draw.
// A pack may also fold a group that its shader declares with multi_compile or shader_feature (its
// "keyword_kinds"); the manifest then records the group under the new kind's pragma.
//
// Where each keyword lives is not stored: it follows from the pass's groups in the manifest's order, so the
// compiler, the manifest, the runtime index and both reader APIs cannot disagree. In each pass, the keywords of
// specialization_constant groups, in group order and value order (the off value "" skipped), take constant ids
// kKeywordConstantIdBase, +1, ... (a specialization_constant_int group takes one id, at its place in that order);
// those of dynamic_branch groups take offsets 0, 4, 8, ... in the block.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kiln/manifest.hpp"
#include "kiln/stage_target.hpp"

namespace kiln {

enum class KeywordKind : uint8_t { Variant, DynamicBranch, SpecializationConstant, SpecializationInteger };

inline constexpr std::string_view kDynamicBranchPragma = "dynamic_branch";
inline constexpr std::string_view kSpecializationConstantPragma = "specialization_constant";
inline constexpr std::string_view kSpecializationIntegerPragma = "specialization_constant_int";
inline constexpr uint32_t kKeywordConstantIdBase = 1000;
inline constexpr std::string_view kKeywordBlockName = "_KilnKeywords";
inline constexpr uint32_t kKeywordBlockSet = 0;
inline constexpr uint32_t kKeywordBlockBinding = 62;

// The kind a group's pragma (as the manifest records it) declares.
constexpr KeywordKind keyword_kind(std::string_view pragma) {
  if (pragma.starts_with(kDynamicBranchPragma)) return KeywordKind::DynamicBranch;
  if (pragma.starts_with(kSpecializationIntegerPragma)) return KeywordKind::SpecializationInteger;
  if (pragma.starts_with(kSpecializationConstantPragma)) return KeywordKind::SpecializationConstant;
  return KeywordKind::Variant;
}
constexpr bool is_folded(KeywordKind kind) { return kind != KeywordKind::Variant; }
constexpr bool is_constant(KeywordKind kind) {
  return kind == KeywordKind::SpecializationConstant || kind == KeywordKind::SpecializationInteger;
}
std::string_view keyword_kind_name(KeywordKind kind);  // "variant", or the pragma above
std::optional<KeywordKind> parse_keyword_kind(std::string_view name);  // the names keyword_kind_name gives

// One keyword of a folded group, where it lives in the modules of its pass. A specialization_constant_int group
// lists every value, the off value too (keyword ""), each with the same slot and its own `value`.
struct FoldedKeyword {
  std::string keyword;
  KeywordKind kind = KeywordKind::SpecializationConstant;
  StageMask stages = kAllStageBits;  // the modules that declare it (the group's stages)
  uint32_t slot = 0;                 // specialization constant: its constant id; dynamic branch: its byte offset
  uint32_t value = 1;                // what the slot holds when this keyword is on (int groups: its place)
  uint32_t fallback = 0;             // what it holds when it is off (int groups: the constant's default)
  friend bool operator==(const FoldedKeyword&, const FoldedKeyword&) = default;
};

// The folded keywords of a pass, from its groups (`values`/`pragma`/`stages` of each), in the order above.
std::vector<FoldedKeyword> folded_keywords(const std::vector<ManifestKeywordGroup>& groups);

// What a renderer sets for one variant: each folded keyword of its pass, on or off. Exactly one value of a
// specialization_constant_int group is on; a renderer sets `data()` at `slot` for each value that `sets()`.
struct KeywordValue : FoldedKeyword {
  bool on = false;
  bool sets() const { return on || kind != KeywordKind::SpecializationInteger; }
  uint32_t data() const { return on ? value : fallback; }
  friend bool operator==(const KeywordValue&, const KeywordValue&) = default;
};

}  // namespace kiln
