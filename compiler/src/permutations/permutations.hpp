// SPDX-License-Identifier: Apache-2.0
// Stages 2 and 3: expand each pass's keyword groups into variants, and strip them by constraints,
// scene profiles and the variant budget. Counting comes first and never materializes more than the
// budget, so 2^40 declared variants are refused in microseconds.
#pragma once

#include <optional>

#include "declarations/declarations.hpp"
#include "kiln/model.hpp"

namespace kiln {

struct PassKeywords {
  const PassDefinition* definition = nullptr;
  std::vector<KeywordGroup> groups;
};

// Saturating count: `saturated` means "at least UINT64_MAX".
struct VariantCount {
  uint64_t value = 0;
  bool saturated = false;
  std::string text() const;
};

// What stripping removed from one pass, and why (printed by `kiln build`).
struct StripReport {
  struct ConstraintEffect {
    const Constraint* constraint = nullptr;
    VariantCount removed;  // variants this constraint alone removes from the declared set
  };
  std::vector<ConstraintEffect> constraints;
  VariantCount after_materials;  // after constraints and materials (before scenes)
};

struct PassExpansion {
  VariantCount declared;        // product of group sizes
  VariantCount valid;           // after constraints
  VariantCount kept;            // after constraints, materials and scenes
  std::vector<Variant> variants;  // in odometer order (last group fastest)
  StripReport strip;
};

struct StripRules {
  const std::vector<Constraint>* constraints = nullptr;
  const std::vector<SceneProfile>* scenes = nullptr;      // empty: no scene stripping
  const std::vector<MaterialPreset>* materials = nullptr;  // empty: no material stripping
};

// Reports unknown keywords in constraints and scenes (with the closest declared keyword).
// A pack's "keyword_kinds" (kiln/folded_keywords.hpp): each named group's pragma becomes its new kind's spelling.
// False (reported) when one group's keywords are given different kinds.
bool apply_keyword_kinds(std::vector<PassKeywords>& passes, const PackDefinition& pack, DiagnosticSink& sink);
bool check_rule_keywords(const std::vector<PassKeywords>& passes, const PackDefinition& pack,
                         const std::vector<SceneProfile>& scenes, DiagnosticSink& sink);

// Counts per pass, then either reports BudgetExceeded (naming the largest groups) or expands.
std::optional<std::vector<PassExpansion>> expand_and_strip(const std::vector<PassKeywords>& passes,
                                                           const StripRules& rules, uint64_t budget,
                                                           const PackDefinition& pack, DiagnosticSink& sink);

// Whether one variant passes the constraints (used by the runtime reader's tests and by lint).
bool satisfies_constraints(const PassKeywords& pass, const std::vector<Constraint>& constraints, const Variant& variant);

}  // namespace kiln
