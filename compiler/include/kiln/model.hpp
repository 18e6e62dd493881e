// SPDX-License-Identifier: Apache-2.0
// The nouns of kiln's pipeline: pack definitions, keyword groups, variants, stages and targets.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "kiln/diagnostics.hpp"
#include "kiln/folded_keywords.hpp"
#include "kiln/manifest.hpp"
#include "kiln/stage_target.hpp"

namespace kiln {

// The optimization recipe that follows legalization (docs/design.md, "The optimizer recipe"). Kiln: SPIRV-Tools'
// -O without the passes whose work kiln's legalization has already done; the same modules as -O once IDs are
// compacted. Stock: -O itself (`spirv-opt -O`).
enum class OptimizerRecipe : uint8_t { Kiln, Stock };
std::string_view optimizer_recipe_name(OptimizerRecipe recipe);  // "kiln", "O"
std::optional<OptimizerRecipe> parse_optimizer_recipe(std::string_view name);

// One `#pragma multi_compile ...` line: exactly one of `values` is chosen per variant.
// The "none" value (`_` in the pragma) is stored as the empty string.
struct KeywordGroup {
  std::vector<std::string> values;
  std::string pragma;           // as written: "multi_compile_fragment", "shader_feature_local", ...
  bool material_feature = false;  // shader_feature: only materials that use it need it
  bool local = false;
  StageMask stages = kAllStageBits;  // _vertex / _fragment suffixes narrow this
  SourceLocation declared_at;

  bool has_none() const;
  int index_of(std::string_view keyword) const;  // -1 if absent
  // multi_compile and shader_feature build a module per value; dynamic_branch and specialization_constant fold
  // the group into one module (kiln/folded_keywords.hpp). A pack's "keyword_kinds" rewrite `pragma`.
  KeywordKind kind() const { return keyword_kind(pragma); }
};

// How HLSL registers become Vulkan descriptor bindings (docs/bindings.md). The DXC/slangc model:
// `register(t3, space1)` is set 1, binding 3 + the t shift of space 1; `[[vk::binding(b, s)]]` is taken as
// written, never shifted; a resource with no register gets the first free binding of set 0 at or above its
// class's shift. The default (no shifts) reproduces glslang's plain register numbers.
enum class RegisterClass : uint8_t { B, T, S, U };  // cbuffer, SRV (texture, read-only buffer), sampler, UAV
inline constexpr int kRegisterClassCount = 4;
char register_class_letter(RegisterClass register_class);  // 'b', 't', 's', 'u'
std::optional<RegisterClass> parse_register_class(std::string_view letter);

inline constexpr int64_t kAllSpaces = -1;
// The largest shift, space, binding or set a pack or the command line may give: with any register number below
// 2^31 (glslang's), register + shift stays below 2^32, so no binding wraps around to a small number.
inline constexpr uint32_t kMaxBindingNumber = 999'999'999;

// Every field is optional so that pack, pass and command line can each override the one before.
struct BindingOptions {
  std::map<std::pair<RegisterClass, int64_t>, uint32_t> shifts;  // (class, space or kAllSpaces) -> shift
  std::optional<bool> auto_bind;                // resources without a register: bound automatically (default on)
  std::optional<bool> combined_image_samplers;  // a texture and a sampler at one binding become one combined binding
  std::optional<std::pair<uint32_t, uint32_t>> global_uniform;  // (binding, set) of the implicit $Global block

  void override_with(const BindingOptions& later);  // `later`'s fields win
  uint32_t shift(RegisterClass register_class, uint32_t space) const;  // a space's own shift wins over "all"
  bool auto_binds() const { return auto_bind.value_or(true); }
  bool combines() const { return combined_image_samplers.value_or(false); }
  // One canonical line: cache keys, the no-change check, the manifest and `kiln list` use it.
  std::string canonical() const;
};

// A preprocessor define from the pack definition or the command line: `#define name value`.
struct Define {
  std::string name;
  std::string value = "1";
  friend bool operator==(const Define&, const Define&) = default;
};
// "NAME" or "NAME=VALUE", as -D takes it; nothing when define_problem finds one.
std::optional<Define> parse_define(std::string_view text);
// Why a define cannot be one `#define` line of the preamble, or "" when it can: a name that is not a preprocessor
// identifier, or a value with a line break or another control character, or ending in a backslash (which would
// continue the #define onto the next line and swallow it: -D DIR=C:\shaders\).
std::string define_problem(const Define& define);
bool is_identifier(std::string_view text);

struct PassDefinition {
  std::string name;
  std::filesystem::path source;                      // entry HLSL file of the pass (empty when every stage names its own)
  std::array<std::string, kStageCount> entry_points;  // empty: the pass has no such stage
  std::array<std::filesystem::path, kStageCount> stage_sources;  // each stage's file: its own, or `source`
  StageMask default_entries = 0;  // stages whose entry point is the default "main", not named: a `#pragma vertex` names it
  std::vector<Target> targets;  // the pass's own "targets" (sorted, SPIR-V in); empty: the pack's
  SourceLocation defined_at;
  BindingOptions bindings;      // the pack's, with the pass's own overrides applied
  // A stage's own "bindings" (a stage file written for another register convention), applied over the pass's;
  // absent: the pass's.
  std::array<std::optional<BindingOptions>, kStageCount> stage_bindings;
  std::vector<Define> defines;  // the pack's, then the pass's own

  const BindingOptions& bindings_for(Stage stage) const {
    const auto& own = stage_bindings[static_cast<size_t>(stage)];
    return own ? *own : bindings;
  }
};

// "keyword" may only appear with all of `requires_all`, at least one of `requires_any`, none of `excludes`.
// The manifest records it as it is (ManifestConstraint), so that tools reason about a built pack on its own.
struct Constraint : ManifestConstraint {
  SourceLocation defined_at;
};

// A material preset: the shader_feature keywords one material enables. When a pack lists materials,
// only the shader_feature combinations some material uses are built (Unity strips by materials too).
struct MaterialPreset : ManifestMaterial {
  SourceLocation defined_at;
};

struct PackDefinition {
  std::filesystem::path file;
  std::string text;  // raw JSON, for locating diagnostics
  std::string name;
  std::vector<std::filesystem::path> include_dirs;
  std::vector<Target> targets;
  uint64_t budget = 4096;
  BindingOptions bindings;      // pack level (each pass holds the result with its overrides)
  std::vector<Define> defines;  // pack level
  std::vector<PassDefinition> passes;
  std::vector<Constraint> constraints;
  std::vector<MaterialPreset> materials;  // empty: every shader_feature combination
  // scene_features: feature -> value -> keywords. Values are strings, "true"/"false", or integer ranges
  // "N", "A-B", "A-" for counts. Kept as JSON text: it is also recorded in the manifest.
  std::string scene_features_json;
  // "keyword_kinds": keyword -> the kind its group is built as, whatever its pragma says (folding a library's
  // multi_compile group into one module without editing the library). Every keyword of a group must agree.
  struct KindOverride {
    KeywordKind kind = KeywordKind::Variant;
    SourceLocation defined_at;
  };
  std::map<std::string, KindOverride> keyword_kinds;
  // "lint": {"disable": ["rule-id", ...]}: kiln lint's rules that are off for this pack (docs/lint.md); checked
  // against kiln/lint_rules.def when read.
  std::vector<std::string> lint_disable;
};

// The keyword values one scene can request; everything else is stripped. A profile states what the scene
// uses ("uses": light counts, shadow settings, fog mode... mapped to keywords by the pack's
// scene_features table; "materials": preset names) and/or lists keywords directly ("keywords").
struct SceneProfile {
  std::filesystem::path file;
  std::string text;
  std::string name;
  std::set<std::string> keywords;            // keywords the scene may enable (after resolution)
  std::string uses_json;                     // the raw "uses" object, resolved against the pack
  std::vector<std::string> material_names;  // material presets the scene's objects use
};

// One permutation of a pass: choice[g] indexes KeywordGroup::values of group g.
struct Variant {
  uint32_t pass = 0;
  std::vector<uint16_t> choice;
  friend auto operator<=>(const Variant&, const Variant&) = default;
};

// Sorted list of enabled keywords of a variant (optionally only the groups that touch `stage`).
std::vector<std::string> enabled_keywords(const std::vector<KeywordGroup>& groups, const Variant& variant,
                                          std::optional<Stage> stage = std::nullopt);
std::string join_keywords(const std::vector<std::string>& keywords);  // "A B C" or "<none>"

}  // namespace kiln
