#include "definition/definition.hpp"

#include "kiln/pack_format.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>

namespace kiln {
namespace {

using nlohmann::json;

// Parses JSON text, reporting a syntax error at its line and column.
std::optional<json> parse_json(const std::filesystem::path& file, const std::string& text, DiagnosticSink& sink) {
  try {
    return json::parse(text);
  } catch (const json::parse_error& error) {
    size_t offset = error.byte > 0 ? error.byte - 1 : 0;
    std::string message = error.what();
    // nlohmann prefixes "[json.exception.parse_error.101] parse error at line 1, column 2: "; keep the reason.
    if (size_t colon = message.find(": "); colon != std::string::npos) message = message.substr(colon + 2);
    sink.report(DiagId::JsonSyntax, location_of_offset(file.string(), text, offset), "invalid JSON: " + message);
    return std::nullopt;
  }
}

struct FieldReader {
  const std::filesystem::path& file;
  const std::string& text;
  DiagnosticSink& sink;
  DiagId id;
  bool ok = true;

  SourceLocation at(std::string_view key) const {
    SourceLocation location = locate_json_string(file.string(), text, key);
    if (location.line == 0) location = SourceLocation{file.string(), 1, 1};
    return location;
  }
  void fail(std::string_view key, const std::string& message) {
    ok = false;
    sink.report(id, at(key), message);
  }
  std::optional<std::string> string(const json& object, const char* key, bool required) {
    auto it = object.find(key);
    if (it == object.end()) {
      if (required) fail(key, std::string("missing required field \"") + key + "\"");
      return std::nullopt;
    }
    if (!it->is_string()) {
      fail(key, std::string("field \"") + key + "\" must be a string");
      return std::nullopt;
    }
    return it->get<std::string>();
  }
  // Every field of `object` that is not in `known` is an error, with the closest known one suggested.
  void only(const json& object, const std::vector<std::string_view>& known, const std::string& what) {
    std::vector<std::string> names(known.begin(), known.end());
    for (auto& [key, value] : object.items()) {
      if (std::find(known.begin(), known.end(), key) != known.end()) continue;
      std::vector<std::string> notes;
      if (auto suggestion = closest_match(key, names)) notes.push_back("did you mean \"" + *suggestion + "\"?");
      else notes.push_back("known fields: " + join(names));
      ok = false;
      sink.report(id, at(key), "unknown field \"" + key + "\" in " + what, std::move(notes));
    }
  }
  static std::string join(const std::vector<std::string>& names) {
    std::string out;
    for (const std::string& name : names) out += (out.empty() ? "" : ", ") + name;
    return out;
  }
  std::vector<std::string> strings(const json& object, const char* key) {
    std::vector<std::string> out;
    auto it = object.find(key);
    if (it == object.end()) return out;
    if (!it->is_array()) {
      fail(key, std::string("field \"") + key + "\" must be an array of strings");
      return out;
    }
    for (const json& item : *it) {
      if (!item.is_string()) {
        fail(key, std::string("field \"") + key + "\" must be an array of strings");
        return {};
      }
      out.push_back(item.get<std::string>());
    }
    return out;
  }
};

}  // namespace

const DefinitionFields& definition_fields() {
  static const DefinitionFields fields{
      {"$schema", "name", "description", "shader", "include_dirs", "targets", "budget", "passes", "constraints",
       "materials", "scene_features"},
      {"name", "description", "source", "stages"},
      {"keyword", "requires", "requires_any", "excludes", "reason"},
      {"name", "description", "keywords"},
      {"$schema", "name", "description", "uses", "materials", "keywords"},
  };
  return fields;
}

std::optional<PackDefinition> load_pack_definition(const std::filesystem::path& file, const ReadLimits& limits,
                                                   DiagnosticSink& sink) {
  auto text = read_text_file(file, limits, sink, SourceLocation{file.string(), 0, 0});
  if (!text) return std::nullopt;
  auto root = parse_json(file, *text, sink);
  if (!root) return std::nullopt;
  FieldReader fields{file, *text, sink, DiagId::PackDefinition};
  if (!root->is_object()) {
    fields.fail("", "a pack definition must be a JSON object");
    return std::nullopt;
  }
  fields.only(*root, definition_fields().pack, "the pack definition");
  PackDefinition pack;
  pack.file = file;
  pack.text = *text;
  const std::filesystem::path base = file.parent_path().empty() ? "." : file.parent_path();
  pack.name = fields.string(*root, "name", true).value_or("");
  if (!pack.name.empty() && pack.name.find_first_not_of(kPackNameCharacters) != std::string::npos)
    fields.fail("name", "pack name '" + pack.name + "' may only use letters, digits, '_', '-' and '.'");
  auto default_source = fields.string(*root, "shader", false);
  for (const std::string& dir : fields.strings(*root, "include_dirs")) pack.include_dirs.push_back(base / dir);

  std::vector<std::string> target_names = fields.strings(*root, "targets");
  if (!root->contains("targets")) target_names = {"spirv", "glsl", "gles", "msl"};
  for (const std::string& name : target_names) {
    if (auto target = parse_target(name)) {
      if (std::find(pack.targets.begin(), pack.targets.end(), *target) == pack.targets.end())
        pack.targets.push_back(*target);
    } else {
      fields.fail(name, "unknown target '" + name + "' (expected spirv, glsl, gles or msl)");
    }
  }
  if (std::find(pack.targets.begin(), pack.targets.end(), Target::Spirv) == pack.targets.end())
    pack.targets.insert(pack.targets.begin(), Target::Spirv);  // every other target is made from SPIR-V
  std::sort(pack.targets.begin(), pack.targets.end());

  if (auto it = root->find("budget"); it != root->end()) {
    if (!it->is_number_unsigned() || it->get<uint64_t>() == 0)
      fields.fail("budget", "\"budget\" must be a positive integer");
    else
      pack.budget = it->get<uint64_t>();
  }

  auto passes = root->find("passes");
  if (passes == root->end() || !passes->is_array() || passes->empty()) {
    fields.fail("passes", "\"passes\" must be a non-empty array");
  } else {
    for (const json& item : *passes) {
      if (!item.is_object()) {
        fields.fail("passes", "each pass must be an object");
        continue;
      }
      fields.only(item, definition_fields().pass, "a pass");
      PassDefinition pass;
      pass.name = fields.string(item, "name", true).value_or("");
      pass.defined_at = fields.at(pass.name);
      auto source = fields.string(item, "source", false);
      if (!source && !default_source) fields.fail(pass.name, "pass '" + pass.name + "' has no \"source\" and the pack no \"shader\"");
      pass.source = base / source.value_or(default_source.value_or(""));
      auto stages = item.find("stages");
      if (stages == item.end() || !stages->is_object() || stages->empty()) {
        fields.fail(pass.name, "pass '" + pass.name + "' needs \"stages\": {\"vertex\": \"Entry\", \"fragment\": \"Entry\"}");
        continue;
      }
      for (auto& [stage_text, entry] : stages->items()) {
        auto stage = parse_stage(stage_text);
        if (!stage) {
          fields.fail(stage_text, "unknown stage '" + stage_text + "' (expected vertex or fragment)");
        } else if (!entry.is_string() || entry.get<std::string>().empty()) {
          fields.fail(stage_text, "stage '" + stage_text + "' must name an entry point");
        } else {
          pass.entry_points[static_cast<size_t>(*stage)] = entry.get<std::string>();
        }
      }
      for (const PassDefinition& other : pack.passes)
        if (other.name == pass.name) fields.fail(pass.name, "pass '" + pass.name + "' is defined twice");
      pack.passes.push_back(std::move(pass));
    }
  }

  if (auto constraints = root->find("constraints"); constraints != root->end()) {
    if (!constraints->is_array()) {
      fields.fail("constraints", "\"constraints\" must be an array");
    } else {
      for (const json& item : *constraints) {
        if (!item.is_object()) {
          fields.fail("constraints", "each constraint must be an object");
          continue;
        }
        fields.only(item, definition_fields().constraint, "a constraint");
        Constraint constraint;
        constraint.keyword = fields.string(item, "keyword", true).value_or("");
        constraint.defined_at = fields.at(constraint.keyword);
        constraint.requires_all = fields.strings(item, "requires");
        constraint.requires_any = fields.strings(item, "requires_any");
        constraint.excludes = fields.strings(item, "excludes");
        constraint.reason = fields.string(item, "reason", false).value_or("");
        if (constraint.requires_all.empty() && constraint.requires_any.empty() && constraint.excludes.empty())
          fields.fail(constraint.keyword, "constraint on '" + constraint.keyword +
                                              "' needs \"requires\", \"requires_any\" or \"excludes\"");
        pack.constraints.push_back(std::move(constraint));
      }
    }
  }
  if (auto materials = root->find("materials"); materials != root->end()) {
    if (!materials->is_array()) {
      fields.fail("materials", "\"materials\" must be an array");
    } else {
      for (const json& item : *materials) {
        if (!item.is_object()) {
          fields.fail("materials", "each material must be an object");
          continue;
        }
        fields.only(item, definition_fields().material, "a material preset");
        MaterialPreset material;
        material.name = fields.string(item, "name", true).value_or("");
        material.defined_at = fields.at(material.name);
        for (const std::string& k : fields.strings(item, "keywords")) material.keywords.insert(k);
        pack.materials.push_back(std::move(material));
      }
    }
  }
  if (auto features = root->find("scene_features"); features != root->end()) {
    if (!features->is_object()) fields.fail("scene_features", "\"scene_features\" must be an object: feature -> value -> keywords");
    else pack.scene_features_json = features->dump();
  }
  if (!fields.ok) return std::nullopt;
  return pack;
}

std::optional<SceneProfile> load_scene_profile(const std::filesystem::path& file, const ReadLimits& limits,
                                               DiagnosticSink& sink) {
  auto text = read_text_file(file, limits, sink, SourceLocation{file.string(), 0, 0});
  if (!text) return std::nullopt;
  auto root = parse_json(file, *text, sink);
  if (!root) return std::nullopt;
  FieldReader fields{file, *text, sink, DiagId::SceneProfile};
  if (!root->is_object()) {
    fields.fail("", "a scene profile must be a JSON object");
    return std::nullopt;
  }
  fields.only(*root, definition_fields().scene, "the scene profile");
  SceneProfile scene;
  scene.file = file;
  scene.text = *text;
  scene.name = fields.string(*root, "name", true).value_or("");
  if (!root->contains("keywords") && !root->contains("uses") && !root->contains("materials"))
    fields.fail("name", "a scene profile needs \"uses\", \"materials\" or \"keywords\"");
  for (const std::string& keyword : fields.strings(*root, "keywords")) scene.keywords.insert(keyword);
  scene.material_names = fields.strings(*root, "materials");
  if (auto uses = root->find("uses"); uses != root->end()) {
    if (!uses->is_object()) fields.fail("uses", "\"uses\" must be an object: feature -> value");
    else scene.uses_json = uses->dump();
  }
  if (!fields.ok) return std::nullopt;
  return scene;
}

namespace {

// Whether a scene's value selects a scene_features key: equal strings, "true"/"false" for booleans, and
// "N", "A-B", "A-" ranges for integers.
bool value_matches(const json& value, const std::string& key) {
  if (value.is_string()) return value.get<std::string>() == key;
  if (value.is_boolean()) return key == (value.get<bool>() ? "true" : "false");
  if (!value.is_number_integer()) return false;
  long long n = value.get<long long>();
  size_t dash = key.find('-');
  try {
    if (dash == std::string::npos) return std::stoll(key) == n;
    long long low = std::stoll(key.substr(0, dash));
    bool open = dash + 1 == key.size();
    return n >= low && (open || n <= std::stoll(key.substr(dash + 1)));
  } catch (const std::exception&) {
    return false;
  }
}

}  // namespace

bool resolve_scene_profile(SceneProfile& scene, const std::string& scene_features_json,
                           const std::vector<MaterialPreset>& materials, DiagnosticSink& sink) {
  bool ok = true;
  auto fail = [&](std::string_view needle, std::string message, std::vector<std::string> notes = {}) {
    ok = false;
    SourceLocation at = locate_json_string(scene.file.string(), scene.text, needle);
    if (at.line == 0) at = SourceLocation{scene.file.string(), 1, 1};
    sink.report(DiagId::SceneProfile, at, std::move(message), std::move(notes));
  };
  for (const std::string& name : scene.material_names) {
    auto it = std::find_if(materials.begin(), materials.end(), [&](const MaterialPreset& m) { return m.name == name; });
    if (it == materials.end()) {
      std::vector<std::string> names;
      for (const MaterialPreset& m : materials) names.push_back(m.name);
      std::vector<std::string> notes;
      if (auto suggestion = closest_match(name, names)) notes.push_back("did you mean '" + *suggestion + "'?");
      fail(name, "scene '" + scene.name + "' uses material '" + name + "', which the pack does not define", notes);
      continue;
    }
    scene.keywords.insert(it->keywords.begin(), it->keywords.end());
  }
  if (scene.uses_json.empty()) return ok;
  json uses = json::parse(scene.uses_json);
  json table = scene_features_json.empty() ? json::object() : json::parse(scene_features_json);
  std::vector<std::string> known;
  for (auto& [feature, values] : table.items()) known.push_back(feature);
  for (auto& [feature, value] : uses.items()) {
    if (!table.contains(feature)) {
      std::vector<std::string> notes;
      if (auto suggestion = closest_match(feature, known)) notes.push_back("did you mean '" + *suggestion + "'?");
      fail(feature, "scene '" + scene.name + "' uses feature '" + feature + "', which the pack's scene_features does not map", notes);
      continue;
    }
    // A feature may take several values in one scene (a list): the scene may request each of them.
    std::vector<json> values = value.is_array() ? value.get<std::vector<json>>() : std::vector<json>{value};
    for (const json& v : values) {
      bool matched = false;
      for (auto& [key, keywords] : table.at(feature).items()) {
        if (!value_matches(v, key)) continue;
        matched = true;
        for (const json& k : keywords) scene.keywords.insert(k.get<std::string>());
      }
      if (!matched) {
        std::vector<std::string> keys;
        for (auto& [key, keywords] : table.at(feature).items()) keys.push_back(key);
        std::string list;
        for (const std::string& k : keys) list += (list.empty() ? "" : ", ") + k;
        fail(feature, "scene '" + scene.name + "': feature '" + feature + "' has no mapping for " + v.dump(),
             {"the pack maps: " + list});
      }
    }
  }
  return ok;
}

}  // namespace kiln
