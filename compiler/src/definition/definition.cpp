#include "definition/definition.hpp"

#include "kiln/bounded_json.hpp"
#include "kiln/lint_rule_id.hpp"
#include "kiln/pack_format.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <functional>
#include <optional>
#include <string_view>

namespace kiln {
namespace {

using nlohmann::json;

// Parses JSON text (bounded: kiln/bounded_json.hpp), reporting a syntax error, a number outside the double range, a
// repeated key or nesting too deep at its line and column. The text's size was checked when it was read.
std::optional<json> parse_json(const std::filesystem::path& file, const std::string& text, DiagnosticSink& sink) {
  try {
    return parse_json_bounded(text, {text.size(), kMaxJsonDepth});
  } catch (const JsonDecodeError& error) {
    sink.report(DiagId::JsonSyntax, location_of_offset(file.string(), text, error.offset()),
                std::string("invalid JSON: ") + error.what());
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

// "bindings": {"shifts": [{"register": "t", "shift": 16, "space": 0}], "auto_bind": true,
//              "combined_image_samplers": false, "global_uniform": {"binding": 0, "set": 0}}
BindingOptions read_bindings(FieldReader& fields, const json& object, const std::string& what);

// "defines": {"NAME": "value" | integer | true | false}
std::vector<Define> read_defines(FieldReader& fields, const json& object, const std::string& what);

}  // namespace

const DefinitionFields& definition_fields() {
  static const DefinitionFields fields{
      {"$schema", "name", "description", "shader", "include_dirs", "targets", "budget", "passes", "constraints",
       "materials", "scene_features", "bindings", "defines", "keyword_kinds", "lint"},
      {"name", "description", "source", "stages", "targets", "bindings", "defines"},
      {"keyword", "requires", "requires_any", "excludes", "reason"},
      {"name", "description", "keywords"},
      {"$schema", "name", "description", "uses", "materials", "keywords"},
      {"shifts", "auto_bind", "combined_image_samplers", "global_uniform"},
      {"register", "shift", "space"},
      {"disable"},
  };
  return fields;
}

namespace {

BindingOptions read_bindings(FieldReader& fields, const json& object, const std::string& what) {
  BindingOptions out;
  auto it = object.find("bindings");
  if (it == object.end()) return out;
  if (!it->is_object()) {
    fields.fail("bindings", "\"bindings\" of " + what + " must be an object");
    return out;
  }
  fields.only(*it, definition_fields().bindings, "\"bindings\"");
  auto non_negative = [](const json& value) {
    return value.is_number_unsigned() && value.get<uint64_t>() <= kMaxBindingNumber;
  };
  const std::string up_to = " up to " + std::to_string(kMaxBindingNumber);
  if (auto shifts = it->find("shifts"); shifts != it->end()) {
    if (!shifts->is_array()) fields.fail("shifts", "\"shifts\" must be an array of {\"register\", \"shift\", \"space\"}");
    else
      for (const json& item : *shifts) {
        if (!item.is_object()) {
          fields.fail("shifts", "each shift must be an object {\"register\": \"t\", \"shift\": 16, \"space\": 0}");
          continue;
        }
        fields.only(item, definition_fields().shift, "a shift");
        auto letter = fields.string(item, "register", true);
        auto register_class = letter ? parse_register_class(*letter) : std::nullopt;
        if (letter && !register_class)
          fields.fail(*letter, "unknown register class '" + *letter + "' (expected b, t, s or u)");
        auto shift = item.find("shift");
        if (shift == item.end() || !non_negative(*shift)) {
          fields.fail("shift", "a shift needs \"shift\": a non-negative integer" + up_to);
          continue;
        }
        int64_t space = kAllSpaces;
        if (auto s = item.find("space"); s != item.end()) {
          if (non_negative(*s)) space = s->get<int64_t>();
          else if (!(s->is_string() && s->get<std::string>() == "all"))
            fields.fail("space", "\"space\" must be a non-negative integer" + up_to + " or \"all\"");
        }
        if (register_class) out.shifts[{*register_class, space}] = shift->get<uint32_t>();
      }
  }
  for (const char* flag : {"auto_bind", "combined_image_samplers"}) {
    auto value = it->find(flag);
    if (value == it->end()) continue;
    if (!value->is_boolean()) fields.fail(flag, std::string("\"") + flag + "\" must be true or false");
    else (std::string(flag) == "auto_bind" ? out.auto_bind : out.combined_image_samplers) = value->get<bool>();
  }
  if (auto global = it->find("global_uniform"); global != it->end()) {
    auto binding = global->is_object() ? global->find("binding") : global->end();
    if (!global->is_object() || binding == global->end() || !non_negative(*binding) ||
        (global->contains("set") && !non_negative(global->at("set"))) || global->size() > (global->contains("set") ? 2u : 1u))
      fields.fail("global_uniform", "\"global_uniform\" must be {\"binding\": N, \"set\": M} (\"set\" defaults to 0; each a "
                                    "non-negative integer" + up_to + ")");
    else
      out.global_uniform = std::make_pair(binding->get<uint32_t>(), global->value("set", uint32_t{0}));
  }
  return out;
}

std::vector<Define> read_defines(FieldReader& fields, const json& object, const std::string& what) {
  std::vector<Define> out;
  auto it = object.find("defines");
  if (it == object.end()) return out;
  if (!it->is_object()) {
    fields.fail("defines", "\"defines\" of " + what + " must be an object: name -> value");
    return out;
  }
  for (auto& [name, value] : it->items()) {
    Define define{name, "1"};
    if (value.is_string()) define.value = value.get<std::string>();
    else if (value.is_number_integer()) define.value = value.dump();
    else if (value.is_boolean()) define.value = value.get<bool>() ? "1" : "0";
    else fields.fail(name, "define '" + name + "' must have a string, integer or boolean value");
    if (std::string problem = define_problem(define); !problem.empty()) fields.fail(name, "define: " + problem);
    out.push_back(std::move(define));
  }
  return out;
}

}  // namespace

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
  if (auto name = fields.string(*root, "name", true)) {
    pack.name = *name;
    if (std::string problem = name_problem(pack.name); !problem.empty())
      fields.fail("name", "pack name '" + echoed(pack.name) + "' " + problem);
  }
  auto default_source = fields.string(*root, "shader", false);
  for (const std::string& dir : fields.strings(*root, "include_dirs")) pack.include_dirs.push_back(base / dir);

  // A "targets" list (the pack's, or a pass's own): known names, SPIR-V always in (every other target is made from
  // it), sorted.
  auto read_targets = [&](const json& object) {
    std::vector<Target> targets;
    for (const std::string& name : fields.strings(object, "targets")) {
      if (auto target = parse_target(name)) {
        if (std::find(targets.begin(), targets.end(), *target) == targets.end()) targets.push_back(*target);
      } else {
        fields.fail(name, "unknown target '" + name + "' (expected " + target_name_list() + ")");
      }
    }
    if (std::find(targets.begin(), targets.end(), Target::Spirv) == targets.end()) targets.insert(targets.begin(), Target::Spirv);
    std::sort(targets.begin(), targets.end());
    return targets;
  };
  if (root->contains("targets")) {
    pack.targets = read_targets(*root);
  } else {
    for (const TargetName& target : kTargetNames) pack.targets.push_back(target.target);
  }

  if (auto it = root->find("budget"); it != root->end()) {
    if (!it->is_number_unsigned() || it->get<uint64_t>() == 0)
      fields.fail("budget", "\"budget\" must be a positive integer");
    else
      pack.budget = it->get<uint64_t>();
  }

  pack.bindings = read_bindings(fields, *root, "the pack");
  pack.defines = read_defines(fields, *root, "the pack");

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
      if (item.contains("name") && item["name"].is_string())
        if (std::string problem = name_problem(pass.name); !problem.empty())
          fields.fail(pass.name, "pass name '" + echoed(pass.name) + "' " + problem + " (it names the pass's --emit directory)");
      auto source = fields.string(item, "source", false);
      if (source || default_source) pass.source = base / source.value_or(default_source.value_or(""));
      auto stages = item.find("stages");
      // No "stages": the entry points come from the source's Unity pragmas (`#pragma vertex vert`), which the
      // declaration scan reads (apply_stage_pragmas); a pass with neither is an error there.
      if ((stages == item.end() && pass.source.empty()) || (stages != item.end() && (!stages->is_object() || stages->empty()))) {
        fields.fail(pass.name, "pass '" + pass.name + "' needs \"stages\": {\"vertex\": \"Entry\", \"fragment\": \"Entry\"}" +
                                   (pass.source.empty() ? std::string() : ", or no \"stages\" to take them from '#pragma vertex NAME' and '#pragma fragment NAME' in its source"));
        continue;
      }
      // A stage names its entry point in the pass's source ("vertex": "VSMain"), or a file of its own with its entry
      // point ("vertex": {"source": "Sky.vert.hlsl", "entry": "main"}), as stage-per-file projects write them.
      // A stage of its own file may have "bindings" of its own, over the pass's.
      std::array<std::optional<BindingOptions>, kStageCount> own_bindings;
      const json no_stages = json::object();
      for (auto& [stage_text, value] : (stages == item.end() ? no_stages : *stages).items()) {
        auto stage = parse_stage(stage_text);
        std::string entry;
        std::optional<std::string> own_source;
        if (value.is_object()) {
          fields.only(value, {"source", "entry", "bindings"}, "a stage");
          own_source = fields.string(value, "source", true);
          const std::optional<std::string> named = fields.string(value, "entry", false);
          entry = named.value_or("main");
          if (!named && stage) pass.default_entries |= stage_bit(*stage);
          if (stage && value.contains("bindings"))
            own_bindings[static_cast<size_t>(*stage)] = read_bindings(fields, value, "stage '" + stage_text + "' of pass '" + pass.name + "'");
        } else if (value.is_string()) {
          entry = value.get<std::string>();
        }
        if (!stage) {
          std::string names;
          for (const StageName& known : kStageNames) names += (names.empty() ? "" : ", ") + std::string(known.name);
          fields.fail(stage_text, "unknown stage '" + stage_text + "' (expected one of " + names + ")");
        } else if (entry.empty()) {
          fields.fail(stage_text, "stage '" + stage_text + "' must name an entry point, or {\"source\": FILE, \"entry\": NAME}");
        } else if (!own_source && pass.source.empty()) {
          fields.fail(pass.name, "pass '" + pass.name + "' has no \"source\" (and the pack no \"shader\") for its " + stage_text +
                                     " stage: give the pass one, or the stage {\"source\": FILE, \"entry\": NAME}");
        } else {
          pass.entry_points[static_cast<size_t>(*stage)] = entry;
          pass.stage_sources[static_cast<size_t>(*stage)] = own_source ? base / *own_source : pass.source;
        }
      }
      if (item.contains("targets")) pass.targets = read_targets(item);  // the pass's own, instead of the pack's
      pass.bindings = pack.bindings;
      pass.bindings.override_with(read_bindings(fields, item, "pass '" + pass.name + "'"));
      for (size_t s = 0; s < kStageCount; ++s)
        if (own_bindings[s]) {
          pass.stage_bindings[s] = pass.bindings;
          pass.stage_bindings[s]->override_with(*own_bindings[s]);
        }
      pass.defines = pack.defines;
      for (Define& define : read_defines(fields, item, "pass '" + pass.name + "'")) {
        std::erase_if(pass.defines, [&](const Define& d) { return d.name == define.name; });  // the pass's value wins
        pass.defines.push_back(std::move(define));
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
  if (auto kinds = root->find("keyword_kinds"); kinds != root->end()) {
    if (!kinds->is_object()) {
      fields.fail("keyword_kinds", "\"keyword_kinds\" must be an object: keyword -> \"variant\", \"dynamic_branch\", "
                                   "\"specialization_constant\" or \"specialization_constant_int\"");
    } else {
      for (auto& [keyword, value] : kinds->items()) {
        const std::optional<KeywordKind> kind = parse_keyword_kind(value.is_string() ? value.get<std::string>() : "");
        PackDefinition::KindOverride entry{kind.value_or(KeywordKind::Variant), fields.at(keyword)};
        if (!kind)
          fields.fail(keyword, "the kind of keyword '" + keyword +
                                   "' must be \"variant\", \"dynamic_branch\", \"specialization_constant\" or "
                                   "\"specialization_constant_int\"");
        if (!is_identifier(keyword)) fields.fail(keyword, "'" + keyword + "' is not a valid keyword name");
        pack.keyword_kinds[keyword] = entry;
      }
    }
  }
  if (auto lint = root->find("lint"); lint != root->end()) {
    if (!lint->is_object()) {
      fields.fail("lint", "\"lint\" must be an object: {\"disable\": [\"rule-id\", ...]}");
    } else {
      fields.only(*lint, definition_fields().lint, "\"lint\"");
      std::vector<std::string> rule_ids(kRuleIdTexts.begin(), kRuleIdTexts.end());
      for (const std::string& rule : fields.strings(*lint, "disable")) {
        if (parse_rule_id(rule)) {
          pack.lint_disable.push_back(rule);
          continue;
        }
        // A misspelt rule would silently disable nothing.
        const std::optional<std::string> suggestion = closest_match(rule, rule_ids);
        const bool printable = rule.size() <= 64 && std::all_of(rule.begin(), rule.end(), [](char c) {
          return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '_';
        });  // a name from the file is quoted only when it cannot carry a control sequence
        fields.fail(rule, "unknown lint rule" + (printable ? " '" + rule + "'" : std::string()) + " in \"lint\": \"disable\"" +
                              (suggestion ? " (did you mean '" + *suggestion + "'?)" : " (the rules are in docs/lint.md)"));
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

namespace {

const SourceLocation kCommandLine{"<command line>", 0, 0};

// The JSON fields' rule (kMaxBindingNumber): up to 9 digits.
std::optional<uint32_t> command_line_number(const std::string& text) {
  static_assert(kMaxBindingNumber == 999'999'999, "the digit count below follows the limit");
  if (text.empty() || text.size() > 9 || text.find_first_not_of("0123456789") != std::string::npos) return std::nullopt;
  return static_cast<uint32_t>(std::stoul(text));
}

}  // namespace

std::optional<std::map<std::string, KeywordKind>> parse_command_line_keyword_kinds(const std::vector<std::string>& texts,
                                                                                 DiagnosticSink& sink) {
  std::map<std::string, KeywordKind> kinds;
  bool ok = true;
  for (const std::string& text : texts) {
    const size_t equals = text.rfind('=');
    const std::optional<KeywordKind> kind =
        equals == std::string::npos ? std::nullopt : parse_keyword_kind(std::string_view(text).substr(equals + 1));
    std::vector<std::string> keywords;
    for (size_t at = 0; equals != std::string::npos && at <= equals;) {
      const size_t end = std::min(text.find(',', at), equals);
      keywords.push_back(text.substr(at, end - at));
      at = end + 1;
    }
    const bool named = !keywords.empty() && std::all_of(keywords.begin(), keywords.end(), is_identifier);
    if (!kind || !named) {
      ok = false;
      sink.report(DiagId::InvalidCommandLineOption, kCommandLine,
                  "--keyword-kind '" + text + "': expected KEYWORD[,KEYWORD...]=KIND, the kind variant, dynamic_branch, "
                  "specialization_constant or specialization_constant_int");
      continue;
    }
    for (const std::string& keyword : keywords) kinds[keyword] = *kind;  // the last one given wins
  }
  if (!ok) return std::nullopt;
  return kinds;
}

std::optional<std::vector<Define>> parse_command_line_defines(const std::vector<std::string>& texts, DiagnosticSink& sink) {
  std::vector<Define> defines;
  bool ok = true;
  for (const std::string& text : texts) {
    if (auto define = parse_define(text)) {
      std::erase_if(defines, [&](const Define& d) { return d.name == define->name; });  // the last -D wins
      defines.push_back(*define);
    } else {
      ok = false;
      const size_t equals = text.find('=');
      const Define refused{text.substr(0, equals), equals == std::string::npos ? "1" : text.substr(equals + 1)};
      sink.report(DiagId::InvalidCommandLineOption, kCommandLine,
                  "-D '" + echoed(text) + "': " + define_problem(refused) + " (expected -D NAME or -D NAME=VALUE)");
    }
  }
  if (!ok) return std::nullopt;
  return defines;
}

bool parse_command_line_shift(RegisterClass register_class, const std::string& shift, const std::string& space,
                              BindingOptions& options, DiagnosticSink& sink) {
  auto value = command_line_number(shift);
  auto space_number = space == "all" ? std::optional<uint32_t>(0) : command_line_number(space);
  if (!value || !space_number) {
    sink.report(DiagId::InvalidCommandLineOption, kCommandLine,
                std::string("--fvk-") + register_class_letter(register_class) + "-shift " + shift + " " + space +
                    ": expected a shift and a register space, both non-negative integers (the space may be 'all')");
    return false;
  }
  options.shifts[{register_class, space == "all" ? kAllSpaces : int64_t{*space_number}}] = *value;
  return true;
}

bool parse_command_line_globals(const std::string& binding, const std::string& set, BindingOptions& options,
                                DiagnosticSink& sink) {
  auto b = command_line_number(binding), s = command_line_number(set);
  if (!b || !s) {
    sink.report(DiagId::InvalidCommandLineOption, kCommandLine,
                "--fvk-bind-globals " + binding + " " + set + ": expected a binding and a descriptor set, both non-negative integers");
    return false;
  }
  options.global_uniform = std::make_pair(*b, *s);
  return true;
}

void apply_command_line(PackDefinition& pack, const BindingOptions& bindings, const std::vector<Define>& defines) {
  pack.bindings.override_with(bindings);
  for (PassDefinition& pass : pack.passes) {
    pass.bindings.override_with(bindings);
    for (std::optional<BindingOptions>& own : pass.stage_bindings)
      if (own) own->override_with(bindings);
    for (const Define& define : defines) {
      std::erase_if(pass.defines, [&](const Define& d) { return d.name == define.name; });
      pass.defines.push_back(define);
    }
  }
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
  if (auto name = fields.string(*root, "name", true)) {
    scene.name = *name;
    if (std::string problem = name_problem(scene.name); !problem.empty())
      fields.fail("name", "scene name '" + echoed(scene.name) + "' " + problem);
  }
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

// --shard I/N (0 <= I < N), or auto: Slurm job arrays (SLURM_ARRAY_TASK_ID with SLURM_ARRAY_TASK_COUNT, or with
// SLURM_ARRAY_TASK_MIN/MAX), GitLab parallel jobs (CI_NODE_INDEX, 1-based, and CI_NODE_TOTAL), Kubernetes Indexed
// Jobs (JOB_COMPLETION_INDEX; Kubernetes exports no count, so the job passes its completions as KILN_SHARD_COUNT).
// Counts and indices are plain decimal numbers of at most 9 digits (no sign, no suffix, nothing that a 32-bit
// conversion could wrap), and a count is at most kMaxShardCount.
namespace {

std::optional<long> shard_number(std::string_view text) {
  if (text.empty() || text.size() > 9 || text.find_first_not_of("0123456789") != std::string_view::npos) return std::nullopt;
  return std::stol(std::string(text));
}

}  // namespace

Result<Shard> parse_shard_option(const std::string& text, const std::function<const char*(const char*)>& environment) {
  std::string bad_variable;  // the first variable that is set but not a number
  auto number = [&](const char* name) -> std::optional<long> {
    const char* value = environment(name);
    if (!value || !*value) return std::nullopt;
    auto n = shard_number(value);
    if (!n && bad_variable.empty()) bad_variable = name + std::string("='") + value + "'";
    return n;
  };
  long index = -1, count = 0;
  std::string read;  // what --shard auto read, for its error
  auto variable = [&](const char* name) { return std::string(name) + "=" + environment(name); };
  if (text == "auto") {
    for (const char* name : {"SLURM_ARRAY_TASK_ID", "SLURM_ARRAY_TASK_COUNT", "SLURM_ARRAY_TASK_MIN", "SLURM_ARRAY_TASK_MAX",
                             "CI_NODE_INDEX", "CI_NODE_TOTAL", "JOB_COMPLETION_INDEX", "KILN_SHARD_COUNT"})
      number(name);
    if (!bad_variable.empty())
      return failure("--shard auto read " + bad_variable + ", which is not a number (a decimal integer of at most 9 digits)");
    if (auto id = number("SLURM_ARRAY_TASK_ID")) {
      if (auto n = number("SLURM_ARRAY_TASK_COUNT")) index = *id, count = *n, read = variable("SLURM_ARRAY_TASK_COUNT");
      auto min = number("SLURM_ARRAY_TASK_MIN"), max = number("SLURM_ARRAY_TASK_MAX");
      if (min && max)
        index = *id - *min, count = *max - *min + 1,
        read = variable("SLURM_ARRAY_TASK_MIN") + ", " + variable("SLURM_ARRAY_TASK_MAX");
      read = variable("SLURM_ARRAY_TASK_ID") + (read.empty() ? "" : ", " + read);
    } else if (auto node = number("CI_NODE_INDEX"), total = number("CI_NODE_TOTAL"); node && total) {
      index = *node - 1, count = *total, read = variable("CI_NODE_INDEX") + ", " + variable("CI_NODE_TOTAL");
    } else if (auto completion = number("JOB_COMPLETION_INDEX")) {
      auto n = number("KILN_SHARD_COUNT");
      if (!n)
        return failure("--shard auto found JOB_COMPLETION_INDEX (a Kubernetes Indexed Job) but no KILN_SHARD_COUNT: set it to "
               "the job's completions");
      index = *completion, count = *n, read = variable("JOB_COMPLETION_INDEX") + ", " + variable("KILN_SHARD_COUNT");
    } else {
      return failure("--shard auto found no SLURM_ARRAY_TASK_ID, CI_NODE_INDEX/CI_NODE_TOTAL or JOB_COMPLETION_INDEX in the "
             "environment");
    }
  } else if (const size_t slash = text.find('/'); slash != std::string::npos) {
    auto i = shard_number(std::string_view(text).substr(0, slash)), n = shard_number(std::string_view(text).substr(slash + 1));
    if (i && n) index = *i, count = *n;
  }
  if (count > long{kMaxShardCount})
    return failure("--shard: " + std::to_string(count) + " shards is more than kiln splits a build into (" +
           std::to_string(kMaxShardCount) + ")" + (read.empty() ? "" : ", read from " + read));
  if (count < 1 || index < 0 || index >= count) {
    if (!read.empty())
      return failure("--shard auto read shard " + std::to_string(index) + " of " + std::to_string(count) + " from " + read +
             ": a shard's index must be at least 0 and below the count (does the count match the scheduler's?)");
    return failure("--shard wants I/N with I < N, or auto (got '" + text + "')");
  }
  return Shard{static_cast<unsigned>(index), static_cast<unsigned>(count)};
}

}  // namespace kiln
