// SPDX-License-Identifier: Apache-2.0
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
  KeywordKind keyword_kind;  // what the group's keywords become (kiln/keyword_kinds.def)
  bool material_feature;     // shader_feature: stripped unless a material uses it (a lone keyword may be off)
  bool takes_suffixes;       // _local, then _vertex or _fragment
  std::span<const std::string_view> implied_values;  // non-empty: the pragma declares these and takes no keywords
};

inline constexpr std::string_view kFogValues[] = {"", "FOG_LINEAR", "FOG_EXP", "FOG_EXP2"};
// Unity's GPU instancing keyword: `#pragma multi_compile_instancing` is `multi_compile _ INSTANCING_ON`.
inline constexpr std::string_view kInstancingValues[] = {"", "INSTANCING_ON"};
// Unity's pragmas, then one per folded keyword kind, named as the kind. The classifier below does not depend on
// the order: an exact name wins, then the longest name that starts the pragma.
inline constexpr KeywordPragmaKind kKeywordPragmaKinds[] = {
    {"multi_compile_fog", KeywordKind::Variant, false, false, kFogValues},
    {"multi_compile_instancing", KeywordKind::Variant, false, false, kInstancingValues},
    {"multi_compile", KeywordKind::Variant, false, true, {}},
    {"shader_feature", KeywordKind::Variant, true, true, {}},
#define KILN_KEYWORD_KIND(kind, name, folded, constant, c_constant, what) \
  {(folded) ? std::string_view(name) : std::string_view(), KeywordKind::kind, false, true, {}},
#include "kiln/keyword_kinds.def"
#undef KILN_KEYWORD_KIND
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
  const KeywordPragmaKind* found = nullptr;
  for (const KeywordPragmaKind& kind : kKeywordPragmaKinds) {
    if (kind.name.empty()) continue;
    if (!kind.takes_suffixes && pragma == kind.name) return KeywordPragma{&kind};
    if (kind.takes_suffixes && pragma.starts_with(kind.name) && (!found || kind.name.size() > found->name.size()))
      found = &kind;
  }
  if (!found) return std::nullopt;
  KeywordPragma result{found};
  std::string_view rest = pragma.substr(found->name.size());
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
static_assert(classify_keyword_pragma("multi_compile_fog")->kind->implied_values.size() == 4);
// The compiler's classifier and the reader's (kiln/folded_keywords.hpp keyword_kind, for a manifest's pragma) agree.
static_assert(classify_keyword_pragma("specialization_constant_int_local")->kind->keyword_kind ==
              keyword_kind("specialization_constant_int_local"));
static_assert(classify_keyword_pragma("dynamic_branch_fragment")->kind->keyword_kind == keyword_kind("dynamic_branch_fragment"));

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
