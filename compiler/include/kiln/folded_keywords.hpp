// SPDX-License-Identifier: Apache-2.0
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

// The rows of kiln/keyword_kinds.def.
enum class KeywordKind : uint8_t {
#define KILN_KEYWORD_KIND(kind, name, folded, constant, c_constant, what) kind,
#include "kiln/keyword_kinds.def"
#undef KILN_KEYWORD_KIND
};

struct KeywordKindRow {
  KeywordKind kind;
  std::string_view name;  // also its pragma, for a folded kind
  bool folded;
  bool constant;
  std::string_view what;
};

inline constexpr KeywordKindRow kKeywordKinds[] = {
#define KILN_KEYWORD_KIND(kind, name, folded, constant, c_constant, what) {KeywordKind::kind, name, folded, constant, what},
#include "kiln/keyword_kinds.def"
#undef KILN_KEYWORD_KIND
};

constexpr const KeywordKindRow& keyword_kind_row(KeywordKind kind) { return kKeywordKinds[static_cast<size_t>(kind)]; }
constexpr std::string_view keyword_kind_name(KeywordKind kind) { return keyword_kind_row(kind).name; }
constexpr bool is_folded(KeywordKind kind) { return keyword_kind_row(kind).folded; }
constexpr bool is_constant(KeywordKind kind) { return keyword_kind_row(kind).constant; }
// The names keyword_kind_name gives.
constexpr std::optional<KeywordKind> parse_keyword_kind(std::string_view name) {
  for (const KeywordKindRow& row : kKeywordKinds)
    if (row.name == name) return row.kind;
  return std::nullopt;
}

inline constexpr std::string_view kDynamicBranchPragma = keyword_kind_name(KeywordKind::DynamicBranch);
inline constexpr std::string_view kSpecializationConstantPragma = keyword_kind_name(KeywordKind::SpecializationConstant);
inline constexpr std::string_view kSpecializationIntegerPragma = keyword_kind_name(KeywordKind::SpecializationInteger);
inline constexpr uint32_t kKeywordConstantIdBase = 1000;
inline constexpr std::string_view kKeywordBlockName = "_KilnKeywords";
inline constexpr uint32_t kKeywordBlockSet = 0;
inline constexpr uint32_t kKeywordBlockBinding = 62;

// The kind a group's pragma (as the manifest records it, `specialization_constant_int_local_fragment`) declares:
// the folded kind whose name is the longest that starts the pragma, so that no row's order matters
// (specialization_constant is a prefix of specialization_constant_int); any other pragma declares variants.
constexpr KeywordKind keyword_kind(std::string_view pragma) {
  KeywordKind found = KeywordKind::Variant;
  size_t longest = 0;
  for (const KeywordKindRow& row : kKeywordKinds)
    if (row.folded && row.name.size() > longest && pragma.starts_with(row.name)) {
      found = row.kind;
      longest = row.name.size();
    }
  return found;
}
static_assert(keyword_kind("specialization_constant_int_local") == KeywordKind::SpecializationInteger);
static_assert(keyword_kind("specialization_constant_fragment") == KeywordKind::SpecializationConstant);
static_assert(keyword_kind("multi_compile_local") == KeywordKind::Variant);

// The kinds' names for a message, quoted with `quote`: "variant, dynamic_branch, specialization_constant or
// specialization_constant_int"; `folded_only`: without variant.
inline std::string keyword_kind_list(std::string_view quote = {}, bool folded_only = false) {
  std::vector<std::string_view> names;
  for (const KeywordKindRow& row : kKeywordKinds)
    if (row.folded || !folded_only) names.push_back(row.name);
  std::string out;
  for (size_t i = 0; i < names.size(); ++i)
    out += std::string(i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + std::string(quote) + std::string(names[i]) +
           std::string(quote);
  return out;
}

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
