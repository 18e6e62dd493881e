// SPDX-License-Identifier: Apache-2.0
#include "permutations/permutations.hpp"

#include "common/keyword_pragmas.hpp"

#include <algorithm>
#include <functional>
#include <limits>

namespace kiln {

std::string VariantCount::text() const {
  return saturated ? "more than " + std::to_string(std::numeric_limits<uint64_t>::max()) : std::to_string(value);
}

namespace {

VariantCount multiply(VariantCount a, uint64_t b) {
  if (a.saturated) return a;
  if (b != 0 && a.value > std::numeric_limits<uint64_t>::max() / b) return {std::numeric_limits<uint64_t>::max(), true};
  return {a.value * b, false};
}

struct KeywordRef {
  int group = -1;
  int value = -1;
};

KeywordRef find_keyword(const std::vector<KeywordGroup>& groups, const std::string& keyword) {
  for (size_t g = 0; g < groups.size(); ++g) {
    int v = groups[g].index_of(keyword);
    if (v >= 0 && !keyword.empty()) return {static_cast<int>(g), v};
  }
  return {};
}

// A constraint bound to one pass's group indices.
struct BoundConstraint {
  KeywordRef subject;
  std::vector<KeywordRef> requires_all;  // group -1: not declared in this pass, never satisfiable
  std::vector<KeywordRef> requires_any;
  std::vector<KeywordRef> excludes;
  int last_group = 0;  // decidable once groups [0, last_group] are chosen

  bool holds(const std::vector<uint16_t>& choice) const {
    if (choice[subject.group] != subject.value) return true;
    auto chosen = [&](const KeywordRef& k) { return k.group >= 0 && choice[k.group] == k.value; };
    if (!std::all_of(requires_all.begin(), requires_all.end(), chosen)) return false;
    if (!requires_any.empty() && !std::any_of(requires_any.begin(), requires_any.end(), chosen)) return false;
    return std::none_of(excludes.begin(), excludes.end(), chosen);
  }
};

std::vector<BoundConstraint> bind_constraints(const PassKeywords& pass, const std::vector<Constraint>& constraints) {
  std::vector<BoundConstraint> bound;
  for (const Constraint& c : constraints) {
    BoundConstraint b;
    b.subject = find_keyword(pass.groups, c.keyword);
    if (b.subject.group < 0) continue;  // the pass does not declare it: nothing to constrain
    b.last_group = b.subject.group;
    auto bind = [&](const std::vector<std::string>& names, std::vector<KeywordRef>& out) {
      for (const std::string& name : names) {
        KeywordRef ref = find_keyword(pass.groups, name);
        out.push_back(ref);
        b.last_group = std::max(b.last_group, ref.group);
      }
    };
    bind(c.requires_all, b.requires_all);
    bind(c.requires_any, b.requires_any);
    bind(c.excludes, b.excludes);
    bound.push_back(std::move(b));
  }
  return bound;
}

// Bit v of allowed[scene][group] says whether the scene can request value v of the group.
using SceneMasks = std::vector<std::vector<uint64_t>>;

SceneMasks scene_masks(const PassKeywords& pass, const std::vector<SceneProfile>& scenes) {
  SceneMasks masks;
  for (const SceneProfile& scene : scenes) {
    std::vector<uint64_t> per_group;
    for (const KeywordGroup& group : pass.groups) {
      uint64_t mask = 0;
      bool names_any = false;
      for (size_t v = 0; v < group.values.size(); ++v) {
        if (group.values[v].empty() || scene.keywords.count(group.values[v])) mask |= uint64_t{1} << v;
        if (!group.values[v].empty() && scene.keywords.count(group.values[v])) names_any = true;
      }
      // A group that cannot be off and that the scene does not mention stays whole: the scene has no say in it.
      if (!group.has_none() && !names_any) mask = (group.values.size() >= 64) ? ~uint64_t{0} : (uint64_t{1} << group.values.size()) - 1;
      per_group.push_back(mask);
    }
    masks.push_back(std::move(per_group));
  }
  return masks;
}

// Bit v of allowed[material][group]: only shader_feature groups are restricted, to exactly the
// material's keyword (or off when the material names none of the group).
SceneMasks material_masks(const PassKeywords& pass, const std::vector<MaterialPreset>& materials) {
  SceneMasks masks;
  for (const MaterialPreset& material : materials) {
    std::vector<uint64_t> per_group;
    for (const KeywordGroup& group : pass.groups) {
      uint64_t all = (group.values.size() >= 64) ? ~uint64_t{0} : (uint64_t{1} << group.values.size()) - 1;
      if (!group.material_feature) {
        per_group.push_back(all);
        continue;
      }
      uint64_t mask = 0;
      for (size_t v = 0; v < group.values.size(); ++v)
        if (!group.values[v].empty() && material.keywords.count(group.values[v])) mask |= uint64_t{1} << v;
      if (mask == 0) mask = group.has_none() ? uint64_t{1} << group.index_of("") : all;
      per_group.push_back(mask);
    }
    masks.push_back(std::move(per_group));
  }
  return masks;
}

// Depth-first walk over the groups in `order`, pruning by constraints and scenes; stops after `limit` leaves.
struct Walker {
  const PassKeywords& pass;
  const std::vector<BoundConstraint>& constraints;
  const SceneMasks* scenes;     // null: no scene stripping
  const SceneMasks* materials;  // null: no material stripping
  std::vector<int> order;    // groups to walk; others stay at value 0
  uint64_t limit;
  std::function<void(const std::vector<uint16_t>&)> on_leaf;
  uint64_t leaves = 0;
  std::vector<uint16_t> choice;
  std::vector<std::vector<const BoundConstraint*>> ready_at;  // constraints decidable after order[i]

  void prepare() {
    choice.assign(pass.groups.size(), 0);
    std::vector<int> position(pass.groups.size(), -1);
    for (size_t i = 0; i < order.size(); ++i) position[order[i]] = static_cast<int>(i);
    ready_at.assign(order.size(), {});
    for (const BoundConstraint& c : constraints) {
      int last = -1;
      auto consider = [&](const KeywordRef& k) {
        if (k.group >= 0) last = std::max(last, position[k.group]);
      };
      consider(c.subject);
      for (auto& k : c.requires_all) consider(k);
      for (auto& k : c.requires_any) consider(k);
      for (auto& k : c.excludes) consider(k);
      if (last >= 0) ready_at[last].push_back(&c);
    }
  }

  // A variant survives a filter (scenes, materials) if at least one member of it still allows every choice.
  static uint64_t narrow(const SceneMasks* filter, uint64_t alive, int g, size_t v) {
    if (!filter) return alive;
    for (size_t m = 0; m < filter->size(); ++m)
      if (((*filter)[m][g] >> v & 1) == 0) alive &= ~(uint64_t{1} << m);
    return alive;
  }

  void walk(size_t depth, uint64_t scene_set, uint64_t material_set) {
    if (leaves >= limit) return;
    if (depth == order.size()) {
      ++leaves;
      if (on_leaf) on_leaf(choice);
      return;
    }
    int g = order[depth];
    for (size_t v = 0; v < pass.groups[g].values.size() && leaves < limit; ++v) {
      choice[g] = static_cast<uint16_t>(v);
      uint64_t next_scenes = narrow(scenes, scene_set, g, v);
      uint64_t next_materials = narrow(materials, material_set, g, v);
      if ((scenes && next_scenes == 0) || (materials && next_materials == 0)) continue;
      bool ok = std::all_of(ready_at[depth].begin(), ready_at[depth].end(),
                            [&](const BoundConstraint* c) { return c->holds(choice); });
      if (ok) walk(depth + 1, next_scenes, next_materials);
    }
    choice[g] = 0;
  }

  uint64_t run(uint64_t scene_set, uint64_t material_set) {
    prepare();
    walk(0, scene_set, material_set);
    return leaves;
  }
};

uint64_t all_scenes(size_t count) { return count >= 64 ? ~uint64_t{0} : (uint64_t{1} << count) - 1; }

}  // namespace

bool satisfies_constraints(const PassKeywords& pass, const std::vector<Constraint>& constraints, const Variant& variant) {
  for (const BoundConstraint& c : bind_constraints(pass, constraints))
    if (!c.holds(variant.choice)) return false;
  return true;
}

bool apply_keyword_kinds(std::vector<PassKeywords>& passes, const PackDefinition& pack, DiagnosticSink& sink) {
  bool ok = true;
  for (PassKeywords& pass : passes)
    for (KeywordGroup& group : pass.groups) {
      const std::string* first = nullptr;
      for (const std::string& value : group.values) {
        auto it = pack.keyword_kinds.find(value);
        if (it == pack.keyword_kinds.end()) continue;
        if (first && pack.keyword_kinds.at(*first).kind != it->second.kind) {
          ok = false;
          sink.report(DiagId::PackDefinition, it->second.defined_at,
                      "keyword_kinds gives '" + value + "' the kind " + std::string(keyword_kind_name(it->second.kind)) +
                          " and '" + *first + "' of the same group the kind " +
                          std::string(keyword_kind_name(pack.keyword_kinds.at(*first).kind)) +
                          ": a group is one module or one per value, for all its keywords",
                      {"the group: #pragma " + group.pragma + " at " + group.declared_at.path + ":" +
                       std::to_string(group.declared_at.line)});
          continue;
        }
        if (!first) first = &value;
      }
      if (first) {
        const KeywordKind kind = pack.keyword_kinds.at(*first).kind;
        group.pragma = pragma_of_kind(group, kind);
        // A folded shader_feature group is one module whatever materials use: every value stays (its bool or constant
        // is set at run time), as the pragma the manifest records for it says, and as check-scene and diff-packs
        // read it back. Stripping by materials would only remove variants that cost nothing.
        if (is_folded(kind)) group.material_feature = false;
      }
    }
  return ok;
}

bool check_rule_keywords(const std::vector<PassKeywords>& passes, const PackDefinition& pack,
                         const std::vector<SceneProfile>& scenes, DiagnosticSink& sink) {
  std::vector<std::string> declared;
  for (const PassKeywords& pass : passes)
    for (const KeywordGroup& group : pass.groups)
      for (const std::string& value : group.values)
        if (!value.empty()) declared.push_back(value);
  std::sort(declared.begin(), declared.end());
  declared.erase(std::unique(declared.begin(), declared.end()), declared.end());
  bool ok = true;
  auto check = [&](const std::string& keyword, const std::filesystem::path& file, const std::string& text, DiagId id,
                   const char* where, const SourceLocation* at = nullptr) {
    if (std::binary_search(declared.begin(), declared.end(), keyword)) return;
    ok = false;
    std::vector<std::string> notes;
    if (auto suggestion = closest_match(keyword, declared)) notes.push_back("did you mean '" + *suggestion + "'?");
    sink.report(id, at ? *at : locate_json_string(file.string(), text, keyword),
                std::string("unknown keyword '") + keyword + "' in " + where + ": no pass declares it", notes);
  };
  for (const Constraint& c : pack.constraints) {
    check(c.keyword, pack.file, pack.text, DiagId::UnknownKeyword, "constraint");
    for (const auto* list : {&c.requires_all, &c.requires_any, &c.excludes})
      for (const std::string& k : *list) check(k, pack.file, pack.text, DiagId::UnknownKeyword, "constraint");
  }
  for (const SceneProfile& scene : scenes)
    for (const std::string& k : scene.keywords) check(k, scene.file, scene.text, DiagId::UnknownKeyword, "scene profile");
  for (const auto& [k, kind] : pack.keyword_kinds) {
    const bool command_line = kind.defined_at.line == 0;  // --keyword-kind
    check(k, pack.file, pack.text, DiagId::UnknownKeyword, command_line ? "--keyword-kind" : "keyword_kinds",
          command_line ? &kind.defined_at : nullptr);
  }
  for (const MaterialPreset& material : pack.materials) {
    for (const std::string& k : material.keywords) {
      check(k, pack.file, pack.text, DiagId::UnknownKeyword, "material");
      for (const PassKeywords& pass : passes)
        for (const KeywordGroup& group : pass.groups)
          // A folded group's keywords (kiln/folded_keywords.hpp) are set at run time: a material may name them, as
          // the shader_feature keywords they often were, and strips nothing by them.
          if (!group.material_feature && !is_folded(group.kind()) && group.index_of(k) >= 0) {
            ok = false;
            sink.report(DiagId::PackDefinition, locate_json_string(pack.file.string(), pack.text, k),
                        "material '" + material.name + "' names '" + k + "', which is declared by #pragma " +
                            group.pragma + "; materials may only name shader_feature keywords");
          }
    }
  }
  return ok;
}

std::optional<std::vector<PassExpansion>> expand_and_strip(const std::vector<PassKeywords>& passes,
                                                           const StripRules& rules, uint64_t budget,
                                                           const PackDefinition& pack, DiagnosticSink& sink) {
  static const std::vector<Constraint> no_constraints;
  static const std::vector<SceneProfile> no_scenes;
  const auto& constraints = rules.constraints ? *rules.constraints : no_constraints;
  static const std::vector<MaterialPreset> no_materials;
  const auto& scenes = rules.scenes ? *rules.scenes : no_scenes;
  const auto& materials = rules.materials ? *rules.materials : no_materials;
  if (materials.size() > 64) {
    sink.report(DiagId::PackDefinition, materials[64].defined_at, "at most 64 materials per pack");
    return std::nullopt;
  }
  if (scenes.size() > 64) {
    sink.report(DiagId::SceneProfile, SourceLocation{scenes[64].file.string(), 0, 0}, "at most 64 scene profiles per build");
    return std::nullopt;
  }
  std::vector<PassExpansion> expansions(passes.size());
  VariantCount total{0, false};
  for (size_t p = 0; p < passes.size(); ++p) {
    const PassKeywords& pass = passes[p];
    for (const KeywordGroup& group : pass.groups) {
      if (group.values.size() > 64) {
        sink.report(DiagId::PragmaSyntax, group.declared_at, "a keyword group may have at most 64 values");
        return std::nullopt;
      }
    }
    PassExpansion& e = expansions[p];
    e.declared = {1, false};
    for (const KeywordGroup& group : pass.groups) e.declared = multiply(e.declared, group.values.size());
    std::vector<BoundConstraint> bound = bind_constraints(pass, constraints);

    // Valid count: groups no constraint touches multiply out; only the others are walked.
    std::vector<bool> constrained(pass.groups.size(), false);
    for (const BoundConstraint& c : bound) {
      constrained[c.subject.group] = true;
      for (const auto* list : {&c.requires_all, &c.requires_any, &c.excludes})
        for (const KeywordRef& k : *list)
          if (k.group >= 0) constrained[k.group] = true;
    }
    Walker valid_walker{pass, bound, nullptr, nullptr, {}, std::numeric_limits<uint64_t>::max(), nullptr};
    VariantCount free_product{1, false};
    for (size_t g = 0; g < pass.groups.size(); ++g) {
      if (constrained[g])
        valid_walker.order.push_back(static_cast<int>(g));
      else
        free_product = multiply(free_product, pass.groups[g].values.size());
    }
    e.valid = multiply(free_product, valid_walker.run(0, 0));

    // The strip report: each constraint on its own, then the materials.
    for (size_t c = 0; c < constraints.size(); ++c) {
      std::vector<BoundConstraint> single = bind_constraints(pass, std::vector<Constraint>{constraints[c]});
      if (single.empty()) continue;
      std::vector<bool> touched(pass.groups.size(), false);
      touched[single[0].subject.group] = true;
      for (const auto* list : {&single[0].requires_all, &single[0].requires_any, &single[0].excludes})
        for (const KeywordRef& k : *list)
          if (k.group >= 0) touched[k.group] = true;
      Walker walker{pass, single, nullptr, nullptr, {}, std::numeric_limits<uint64_t>::max(), nullptr};
      VariantCount rest{1, false};
      for (size_t g = 0; g < pass.groups.size(); ++g) {
        if (touched[g]) walker.order.push_back(static_cast<int>(g));
        else rest = multiply(rest, pass.groups[g].values.size());
      }
      VariantCount kept_by_this = multiply(rest, walker.run(0, 0));
      VariantCount removed = e.declared;
      if (!removed.saturated && !kept_by_this.saturated) removed.value -= kept_by_this.value;
      e.strip.constraints.push_back({&constraints[c], removed});
    }
    if (!materials.empty()) {
      // Counted up to a cap: the report only needs "how many", and 2^40-variant packs must stay instant.
      SceneMasks material_filter = material_masks(pass, materials);
      Walker walker{pass, bound, nullptr, &material_filter, {}, uint64_t{1} << 24, nullptr};
      for (size_t g = 0; g < pass.groups.size(); ++g) walker.order.push_back(static_cast<int>(g));
      uint64_t count = walker.run(0, all_scenes(materials.size()));
      e.strip.after_materials = {count, count >= (uint64_t{1} << 24)};
    } else {
      e.strip.after_materials = e.valid;
    }

    // Kept count: with scenes every group matters, so walk them all but stop one past the budget.
    uint64_t remaining = total.saturated || total.value >= budget ? 0 : budget - total.value;
    if (scenes.empty() && materials.empty()) {
      e.kept = e.valid;
    } else {
      SceneMasks masks = scene_masks(pass, scenes);
      SceneMasks material_filter = material_masks(pass, materials);
      Walker kept_walker{pass, bound, scenes.empty() ? nullptr : &masks, materials.empty() ? nullptr : &material_filter,
                         {}, remaining + 1, nullptr};
      for (size_t g = 0; g < pass.groups.size(); ++g) kept_walker.order.push_back(static_cast<int>(g));
      // capped one past the budget
      e.kept = {kept_walker.run(all_scenes(scenes.size()), all_scenes(materials.size())), false};
    }
    if (e.kept.saturated || total.saturated || e.kept.value > std::numeric_limits<uint64_t>::max() - total.value)
      total = {std::numeric_limits<uint64_t>::max(), true};
    else
      total.value += e.kept.value;
  }

  if (total.saturated || total.value > budget) {
    // Name the groups that multiply the most, largest first.
    struct Entry {
      size_t size;
      std::string text;
    };
    std::vector<Entry> largest;
    for (const PassKeywords& pass : passes)
      for (const KeywordGroup& group : pass.groups) {
        std::string values;
        for (const std::string& v : group.values) values += (values.empty() ? "" : " ") + (v.empty() ? std::string("_") : v);
        largest.push_back({group.values.size(), pass.definition->name + ": #pragma " + group.pragma + " " + values + " (" +
                                                    std::to_string(group.values.size()) + " values, " +
                                                    group.declared_at.path + ":" + std::to_string(group.declared_at.line) + ")"});
      }
    std::stable_sort(largest.begin(), largest.end(), [](const Entry& a, const Entry& b) { return a.size > b.size; });
    std::vector<std::string> notes;
    for (size_t i = 0; i < largest.size() && i < 5; ++i) notes.push_back("largest group: " + largest[i].text);
    notes.push_back("strip with constraints or --scene, turn multi_compile into shader_feature, or raise \"budget\"");
    std::string count = total.saturated || total.value > budget ? "more than " + std::to_string(budget) : total.text();
    VariantCount declared_total{0, false};
    for (const PassExpansion& e : expansions) {
      if (e.declared.saturated || declared_total.saturated) {
        declared_total = {std::numeric_limits<uint64_t>::max(), true};
        continue;
      }
      declared_total.value += e.declared.value;
    }
    SourceLocation at = locate_json_string(pack.file.string(), pack.text, "budget");
    if (at.line == 0) at = SourceLocation{pack.file.string(), 0, 0};
    sink.report(DiagId::BudgetExceeded, at,
                "pack '" + pack.name + "' has " + count + " variants after stripping (" + declared_total.text() +
                    " declared), over its budget of " + std::to_string(budget),
                notes);
    return std::nullopt;
  }

  for (size_t p = 0; p < passes.size(); ++p) {
    const PassKeywords& pass = passes[p];
    std::vector<BoundConstraint> bound = bind_constraints(pass, constraints);
    SceneMasks masks = scene_masks(pass, scenes);
    SceneMasks material_filter = material_masks(pass, materials);
    Walker walker{pass, bound, scenes.empty() ? nullptr : &masks, materials.empty() ? nullptr : &material_filter, {},
                  std::numeric_limits<uint64_t>::max(), nullptr};
    for (size_t g = 0; g < pass.groups.size(); ++g) walker.order.push_back(static_cast<int>(g));
    auto& variants = expansions[p].variants;
    walker.on_leaf = [&](const std::vector<uint16_t>& choice) { variants.push_back(Variant{static_cast<uint32_t>(p), choice}); };
    walker.run(all_scenes(scenes.size()), all_scenes(materials.size()));
    if (variants.empty()) {
      sink.report(DiagId::NoVariants, pass.definition->defined_at,
                  "constraints and scene profiles leave pass '" + pass.definition->name + "' with no variant");
      return std::nullopt;
    }
  }
  return expansions;
}

}  // namespace kiln
