#include "tools/pack_tools.hpp"

#include <algorithm>
#include <map>
#include <set>

#include "common/files.hpp"
#include "common/keyword_pragmas.hpp"
#include "definition/definition.hpp"
#include "permutations/permutations.hpp"

namespace kiln {
namespace {

using nlohmann::json;

// Rebuilds the keyword groups, constraints and materials recorded in a manifest.
struct RecordedPass {
  PassDefinition definition;
  std::vector<KeywordGroup> groups;
};

std::vector<KeywordGroup> recorded_groups(const json& pass) {
  std::vector<KeywordGroup> groups;
  for (const json& g : pass.at("keyword_groups")) {
    KeywordGroup group;
    group.pragma = g.value("pragma", "multi_compile");
    group.material_feature = is_material_feature_pragma(group.pragma);
    group.stages = 0;
    for (const json& s : g.value("stages", json::array({"vertex", "fragment"})))
      if (auto stage = parse_stage(s.get<std::string>())) group.stages |= stage_bit(*stage);
    for (const json& v : g.at("values")) group.values.push_back(v == "_" ? "" : v.get<std::string>());
    groups.push_back(std::move(group));
  }
  return groups;
}

std::string join_key(const std::vector<std::string>& keywords) { return join_keywords(keywords); }

// Binary blob ids of a variant, to compare two packs' variants by content.
std::string variant_content(const PackReader& pack, const json& variant) {
  std::string content;
  const json& binaries = pack.manifest().at("binaries");
  for (auto& [stage, index] : variant.at("binaries").items()) {
    std::string_view spirv = pack.blob(binaries.at(index.get<size_t>()).at("blobs").at("spirv").get<uint32_t>());
    content += stage + ":" + std::to_string(std::hash<std::string_view>{}(spirv)) + ";";
  }
  return content;
}

}  // namespace

std::optional<SceneCheck> check_scene(const PackReader& pack, const std::filesystem::path& scene_file, DiagnosticSink& sink) {
  auto scene = load_scene_profile(scene_file, ReadLimits{}, sink);
  if (!scene) return std::nullopt;
  const json& manifest = pack.manifest();
  PackDefinition definition;
  definition.name = pack.name();
  for (const json& c : manifest.value("constraints", json::array())) {
    Constraint constraint;
    constraint.keyword = c.at("keyword").get<std::string>();
    constraint.requires_all = c.value("requires", std::vector<std::string>{});
    constraint.requires_any = c.value("requires_any", std::vector<std::string>{});
    constraint.excludes = c.value("excludes", std::vector<std::string>{});
    definition.constraints.push_back(std::move(constraint));
  }
  for (const json& m : manifest.value("materials", json::array())) {
    MaterialPreset material;
    material.name = m.at("name").get<std::string>();
    for (const json& k : m.at("keywords")) material.keywords.insert(k.get<std::string>());
    definition.materials.push_back(std::move(material));
  }
  for (const json& pass : manifest.at("passes")) definition.passes.push_back(PassDefinition{pass.at("name"), {}, {}, {}});
  std::string features = manifest.contains("scene_features") ? manifest.at("scene_features").dump() : std::string();
  if (!resolve_scene_profile(*scene, features, definition.materials, sink)) return std::nullopt;
  std::vector<PassKeywords> passes;
  for (size_t p = 0; p < definition.passes.size(); ++p)
    passes.push_back(PassKeywords{&definition.passes[p], recorded_groups(manifest.at("passes")[p])});

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
    for (const json& pass : pack.manifest().at("passes"))
      for (const json& v : pass.at("variants")) {
        auto keywords = v.at("keywords").get<std::vector<std::string>>();
        out[{pass.at("name").get<std::string>(), join_key(keywords)}] = {keywords, variant_content(pack, v)};
      }
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
