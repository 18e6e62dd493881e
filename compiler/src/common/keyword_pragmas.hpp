// Keyword pragmas: what each spelling means, stated once. Read by the declaration scanner (stage 1), by the
// tools that rebuild keyword groups from a manifest (which records each group's pragma as written), and by lint.
//   #pragma multi_compile[_local][_vertex|_fragment] A B   every value is built
//   #pragma shader_feature[_local][_vertex|_fragment] A B  built only when a material (or scene) uses it
//   #pragma multi_compile_fog                              _ FOG_LINEAR FOG_EXP FOG_EXP2
//   #pragma multi_compile_instancing                       _ INSTANCING_ON
//   #pragma dynamic_branch[_local][_vertex|_fragment] A B  one module; each keyword a uniform bool (Unity's)
//   #pragma specialization_constant[_local][_vertex|_fragment] A B  one module; each keyword a specialization constant
//   #pragma specialization_constant_int[_local][_vertex|_fragment] A B  one module; one int constant for the group
// (the last two: kiln/folded_keywords.hpp)
#pragma once

#include <optional>
#include <span>
#include <string_view>

#include "kiln/model.hpp"

namespace kiln {

struct KeywordPragmaKind {
  std::string_view name;
  bool material_feature;  // shader_feature: stripped unless a material uses it (a lone keyword may be off)
  bool takes_suffixes;    // _local, then _vertex or _fragment
  std::span<const std::string_view> implied_values;  // non-empty: the pragma declares these and takes no keywords
};

inline constexpr std::string_view kFogValues[] = {"", "FOG_LINEAR", "FOG_EXP", "FOG_EXP2"};
// Unity's GPU instancing keyword: `#pragma multi_compile_instancing` is `multi_compile _ INSTANCING_ON`.
inline constexpr std::string_view kInstancingValues[] = {"", "INSTANCING_ON"};
// Exact names (implied values) first: multi_compile_fog is not multi_compile with a suffix; nor is
// specialization_constant_int specialization_constant with one.
inline constexpr KeywordPragmaKind kKeywordPragmaKinds[] = {
    {"multi_compile_fog", false, false, kFogValues},
    {"multi_compile_instancing", false, false, kInstancingValues},
    {"multi_compile", false, true, {}},
    {"shader_feature", true, true, {}},
    {kDynamicBranchPragma, false, true, {}},
    {kSpecializationIntegerPragma, false, true, {}},
    {kSpecializationConstantPragma, false, true, {}},
};
inline constexpr std::string_view kLocalSuffix = "_local";
struct StageSuffix {
  std::string_view suffix;
  Stage stage;
};
// Unity's stage suffixes (multi_compile_vertex, _fragment, _geometry, _hull, _domain); a compute shader's keywords
// carry none.
inline constexpr StageSuffix kStageSuffixes[] = {{"_vertex", Stage::Vertex},     {"_fragment", Stage::Fragment},
                                                 {"_geometry", Stage::Geometry}, {"_hull", Stage::Hull},
                                                 {"_domain", Stage::Domain}};

struct KeywordPragma {
  const KeywordPragmaKind* kind = nullptr;
  bool local = false;
  StageMask stages = kAllStageBits;
  bool known_suffix = true;  // false: starts like a keyword pragma but its suffix is not one of the above
};

// Nothing when `pragma` is not a keyword pragma at all (`#pragma once`, `#pragma vertex`...).
constexpr std::optional<KeywordPragma> classify_keyword_pragma(std::string_view pragma) {
  for (const KeywordPragmaKind& kind : kKeywordPragmaKinds) {
    if (!kind.takes_suffixes) {
      if (pragma == kind.name) return KeywordPragma{&kind};
      continue;
    }
    if (!pragma.starts_with(kind.name)) continue;
    KeywordPragma result{&kind};
    std::string_view rest = pragma.substr(kind.name.size());
    if (rest.starts_with(kLocalSuffix)) {
      result.local = true;
      rest.remove_prefix(kLocalSuffix.size());
    }
    if (rest.empty()) return result;
    for (const StageSuffix& s : kStageSuffixes)
      if (rest == s.suffix) {
        result.stages = stage_bit(s.stage);
        return result;
      }
    result.known_suffix = false;
    return result;
  }
  return std::nullopt;
}

constexpr bool is_material_feature_pragma(std::string_view pragma) {
  auto kind = classify_keyword_pragma(pragma);
  return kind && kind->kind->material_feature;
}

static_assert(classify_keyword_pragma("shader_feature_local_fragment")->local);
static_assert(classify_keyword_pragma("multi_compile_vertex")->stages == stage_bit(Stage::Vertex));
static_assert(!classify_keyword_pragma("multi_compile_fog")->kind->takes_suffixes);
static_assert(!classify_keyword_pragma("once"));
static_assert(classify_keyword_pragma("specialization_constant_local_fragment")->local);
static_assert(classify_keyword_pragma("dynamic_branch_vertex")->stages == stage_bit(Stage::Vertex));
static_assert(classify_keyword_pragma("specialization_constant_int_local")->kind->name == kSpecializationIntegerPragma);
static_assert(classify_keyword_pragma("specialization_constant_fragment")->kind->name == kSpecializationConstantPragma);

// The pragma that declares `group`'s values and suffixes as `kind` (a pack's "keyword_kinds"): multi_compile_fog
// becomes a folded kind's pragma with its stages kept by the group's mask.
inline std::string pragma_of_kind(const KeywordGroup& group, KeywordKind kind) {
  const std::optional<KeywordPragma> was = classify_keyword_pragma(group.pragma);
  std::string out(is_folded(kind)             ? keyword_kind_name(kind)
                  : group.material_feature ? std::string_view("shader_feature")
                                           : std::string_view("multi_compile"));
  if (was && was->local) out += kLocalSuffix;
  for (const StageSuffix& s : kStageSuffixes)
    if (was && was->stages == stage_bit(s.stage)) out += s.suffix;
  return out;
}

}  // namespace kiln
