// SPDX-License-Identifier: Apache-2.0
#include "kiln/pack_tools.hpp"

#include <algorithm>
#include <limits>
#include <map>
#include <set>

#include "common/files.hpp"
#include "common/keyword_pragmas.hpp"
#include "definition/definition.hpp"
#include "kiln/pack_format.hpp"
#include "kiln/text.hpp"
#include "permutations/permutations.hpp"

namespace kiln {
namespace {

// Rebuilds the keyword groups, constraints and materials recorded in a manifest.
struct RecordedPass {
  PassDefinition definition;
  std::vector<KeywordGroup> groups;
};

std::vector<KeywordGroup> recorded_groups(const ManifestPass& pass) {
  std::vector<KeywordGroup> groups;
  for (const ManifestKeywordGroup& g : pass.keyword_groups) {
    KeywordGroup group;
    group.pragma = g.pragma;
    group.material_feature = is_material_feature_pragma(group.pragma);
    group.stages = g.stages;
    group.values = g.values;
    groups.push_back(std::move(group));
  }
  return groups;
}

std::string join_key(const std::vector<std::string>& keywords) { return join_keywords(keywords); }

// Binary blob ids of a variant, to compare two packs' variants by content.
std::string variant_content(const PackReader& pack, const ManifestVariant& variant) {
  std::string content;
  for (const auto& [stage, index] : variant.binaries) {
    const auto& blobs = pack.manifest().binaries[index].blobs;  // in range: the reader checked
    auto spirv = blobs.find(Target::Spirv);
    const std::string_view bytes = spirv == blobs.end() ? std::string_view{} : pack.blob(spirv->second);
    content += std::string(stage_name(stage)) + ":" + std::to_string(std::hash<std::string_view>{}(bytes)) + ";";
  }
  return content;
}

}  // namespace

std::optional<SceneCheck> check_scene(const PackReader& pack, const std::filesystem::path& scene_file, DiagnosticSink& sink) {
  auto scene = load_scene_profile(scene_file, ReadLimits{}, sink);
  if (!scene) return std::nullopt;
  const Manifest& manifest = pack.manifest();
  PackDefinition definition;
  definition.name = pack.name();
  for (const ManifestConstraint& c : manifest.constraints) definition.constraints.push_back(Constraint{c, {}});
  for (const ManifestMaterial& m : manifest.materials) definition.materials.push_back(MaterialPreset{m, {}});
  for (const ManifestPass& pass : manifest.passes) definition.passes.push_back(PassDefinition{pass.name, {}, {}, {}});
  const std::string& features = manifest.scene_features_json;
  if (!resolve_scene_profile(*scene, features, definition.materials, sink)) return std::nullopt;
  std::vector<PassKeywords> passes;
  for (size_t p = 0; p < definition.passes.size(); ++p)
    passes.push_back(PassKeywords{&definition.passes[p], recorded_groups(manifest.passes[p])});

  // What the scene can request: the scene's keywords, limited by the same constraints and materials the
  // pack was built with, but by no budget.
  std::vector<SceneProfile> scenes{*scene};
  if (!check_rule_keywords(passes, PackDefinition{}, scenes, sink)) return std::nullopt;
  StripRules rules{&definition.constraints, &scenes, &definition.materials};
  auto expansions = expand_and_strip(passes, rules, ~uint64_t{0} >> 1, definition, sink);
  if (!expansions) return std::nullopt;
  SceneCheck result;
  for (size_t p = 0; p < passes.size(); ++p) {
    const std::string& name = definition.passes[p].name;
    for (const Variant& v : (*expansions)[p].variants) {
      ++result.requested;
      std::vector<std::string> keywords = enabled_keywords(passes[p].groups, v);
      try {
        pack.select(name, keywords, true);
      } catch (const PackError&) {
        result.missing.push_back({name, keywords});
      }
    }
  }
  return result;
}

PackDiff diff_packs(const PackReader& a, const PackReader& b) {
  PackDiff diff;
  auto index = [](const PackReader& pack) {
    std::map<std::pair<std::string, std::string>, std::pair<std::vector<std::string>, std::string>> out;
    for (const ManifestPass& pass : pack.manifest().passes)
      for (const ManifestVariant& v : pass.variants) out[{pass.name, join_key(v.keywords)}] = {v.keywords, variant_content(pack, v)};
    return out;
  };
  auto in_a = index(a), in_b = index(b);
  for (const auto& [key, value] : in_b) {
    auto it = in_a.find(key);
    if (it == in_a.end())
      diff.added.push_back({key.first, value.first});
    else if (it->second.second != value.second)
      diff.changed.push_back({key.first, value.first});
  }
  for (const auto& [key, value] : in_a)
    if (!in_b.count(key)) diff.removed.push_back({key.first, value.first});
  return diff;
}

}  // namespace kiln

namespace kiln {

UsageCheck check_usage(const PackReader& pack, const std::vector<UsageLog>& logs, DiagnosticSink& sink) {
  UsageCheck check;
  // Counts from hostile logs cannot wrap: the totals stop at the largest count (docs/usage.md), as merge-usage's do.
  auto add = [](uint64_t& total, uint64_t count) {
    total = count > std::numeric_limits<uint64_t>::max() - total ? std::numeric_limits<uint64_t>::max() : total + count;
  };
  for (const UsageLog& log : logs) {
    const SourceLocation at{log.file.string(), 0, 0};
    if (log.missing_dropped > 0)
      sink.report(DiagId::UsageIncomplete, at,
                  "the recording dropped " + counted(log.missing_dropped, "missing selection") +
                      " (more distinct missing keyword sets than its bound): they are not checked");
    for (const auto& [pass, requests] : log.passes) {
      for (const UsageRequest& request : requests) {
        ++check.sets;
        add(check.requests, request.count);
        auto selected = pack.try_select(pass, request.keywords);
        if (selected) continue;
        ++check.missed;
        add(check.requests_missed, request.count);
        std::string text = "pass '" + echoed(pass, kMaxNameLength) + "': " + keyword_set_text(request.keywords) + ", asked for " +
                           counted(request.count, "time") + ", is not in pack '" + pack.name() + "'";
        std::vector<std::string> notes;
        const std::string& message = selected.message();
        if (const size_t nearest = message.find("nearest variants in the pack: ["); nearest != std::string::npos) {
          const size_t open = message.find('[', nearest), close = message.find(']', open);
          text += "; the nearest variant the reader names is [" + message.substr(open + 1, close - open - 1) + "]";
        } else {
          notes.push_back(message);  // not Stripped: the reader's own words (an unknown pass, a conflict...)
        }
        sink.report(DiagId::UsageNotServed, at, text, std::move(notes));
      }
    }
  }
  return check;
}

}  // namespace kiln
