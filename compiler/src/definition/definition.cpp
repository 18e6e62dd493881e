// SPDX-License-Identifier: Apache-2.0
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
};

// How a pack definition and a scene profile are read: for each kind of object, one row per field, in reading
// order (a row may use what the rows before it read: a pass's "stages" its "source"). The unknown-field check,
// definition_fields() and so the schema test come from the rows. A field whose row has no reader is allowed and
// not read ("$schema", "description"); checks across fields run after the rows ("finish").
struct Reading {
  FieldReader& fields;
  std::filesystem::path base;  // the definition's directory: relative paths are from it
};

template <typename T>
struct Field {
  std::string_view name;
  void (*read)(Reading&, const json& value, T& out) = nullptr;
  bool required = false;
  std::string_view missing = {};  // a required field's error when it is absent; default "missing required field"
};

template <typename T>
std::vector<std::string_view> names_of(const std::vector<Field<T>>& rows) {
  std::vector<std::string_view> names;
  for (const Field<T>& row : rows) names.push_back(row.name);
  return names;
}

// `object`'s fields by `rows`: unknown ones are errors (with the closest known name), known ones read in row order.
template <typename T>
void read_fields(Reading& r, const json& object, const std::vector<Field<T>>& rows, const std::string& what, T& out) {
  r.fields.only(object, names_of(rows), what);
  for (const Field<T>& row : rows) {
    auto it = object.find(row.name);
    if (it == object.end()) {
      if (row.required)
        r.fields.fail(row.name, row.missing.empty() ? "missing required field \"" + std::string(row.name) + "\""
                                                    : std::string(row.missing));
      continue;
    }
    if (row.read) row.read(r, *it, out);
  }
}

std::optional<std::string> string_field(Reading& r, std::string_view key, const json& value) {
  if (value.is_string()) return value.get<std::string>();
  r.fields.fail(key, "field \"" + std::string(key) + "\" must be a string");
  return std::nullopt;
}

std::vector<std::string> strings_field(Reading& r, std::string_view key, const json& value) {
  std::vector<std::string> out;
  const bool strings = value.is_array() && std::all_of(value.begin(), value.end(), [](const json& v) { return v.is_string(); });
  if (!strings) {
    r.fields.fail(key, "field \"" + std::string(key) + "\" must be an array of strings");
    return out;
  }
  for (const json& item : value) out.push_back(item.get<std::string>());
  return out;
}

// An array of objects, each read by `read`.
template <typename Each>
void for_each_object(Reading& r, std::string_view key, const json& value, const char* each, Each&& read) {
  if (!value.is_array()) {
    r.fields.fail(key, "\"" + std::string(key) + "\" must be an array");
    return;
  }
  for (const json& item : value) {
    if (item.is_object()) read(item);
    else r.fields.fail(key, std::string("each ") + each + " must be an object");
  }
}

bool binding_number(const json& value) { return value.is_number_unsigned() && value.get<uint64_t>() <= kMaxBindingNumber; }
const std::string kUpTo = " up to " + std::to_string(kMaxBindingNumber);

// {"register": "t", "shift": 16, "space": 0}
struct ShiftReading {
  std::optional<RegisterClass> register_class;
  std::optional<uint32_t> shift;
  int64_t space = kAllSpaces;
  bool ok = true;
};

const std::vector<Field<ShiftReading>>& shift_fields() {
  static const std::vector<Field<ShiftReading>> rows{
      {"register",
       [](Reading& r, const json& value, ShiftReading& out) {
         if (auto letter = string_field(r, "register", value)) {
           out.register_class = parse_register_class(*letter);
           if (!out.register_class) r.fields.fail(*letter, "unknown register class '" + *letter + "' (expected b, t, s or u)");
         }
       },
       true},
      {"shift",
       [](Reading&, const json& value, ShiftReading& out) {
         if (binding_number(value)) out.shift = value.get<uint32_t>();
       }},
      {"space",
       [](Reading& r, const json& value, ShiftReading& out) {
         if (binding_number(value)) out.space = value.get<int64_t>();
         else if (!(value.is_string() && value.get<std::string>() == "all"))
           r.fields.fail("space", "\"space\" must be a non-negative integer" + kUpTo + " or \"all\"");
       }},
  };
  return rows;
}

void read_bool(Reading& r, std::string_view key, const json& value, std::optional<bool>& out) {
  if (value.is_boolean()) out = value.get<bool>();
  else r.fields.fail(key, "\"" + std::string(key) + "\" must be true or false");
}

// "bindings": {"shifts": [{"register": "t", "shift": 16, "space": 0}], "auto_bind": true,
//              "combined_image_samplers": false, "global_uniform": {"binding": 0, "set": 0}}
const std::vector<Field<BindingOptions>>& binding_fields() {
  static const std::vector<Field<BindingOptions>> rows{
      {"shifts",
       [](Reading& r, const json& value, BindingOptions& out) {
         if (!value.is_array()) {
           r.fields.fail("shifts", "\"shifts\" must be an array of {\"register\", \"shift\", \"space\"}");
           return;
         }
         for (const json& item : value) {
           if (!item.is_object()) {
             r.fields.fail("shifts", "each shift must be an object {\"register\": \"t\", \"shift\": 16, \"space\": 0}");
             continue;
           }
           ShiftReading shift;
           read_fields(r, item, shift_fields(), "a shift", shift);
           if (!shift.shift) r.fields.fail("shift", "a shift needs \"shift\": a non-negative integer" + kUpTo);
           else if (shift.register_class) out.shifts[{*shift.register_class, shift.space}] = *shift.shift;
         }
       }},
      {"auto_bind", [](Reading& r, const json& value, BindingOptions& out) { read_bool(r, "auto_bind", value, out.auto_bind); }},
      {"combined_image_samplers",
       [](Reading& r, const json& value, BindingOptions& out) {
         read_bool(r, "combined_image_samplers", value, out.combined_image_samplers);
       }},
      {"global_uniform",
       [](Reading& r, const json& global, BindingOptions& out) {
         auto binding = global.is_object() ? global.find("binding") : global.end();
         if (!global.is_object() || binding == global.end() || !binding_number(*binding) ||
             (global.contains("set") && !binding_number(global.at("set"))) || global.size() > (global.contains("set") ? 2u : 1u))
           r.fields.fail("global_uniform", "\"global_uniform\" must be {\"binding\": N, \"set\": M} (\"set\" defaults to 0; each "
                                           "a non-negative integer" + kUpTo + ")");
         else
           out.global_uniform = std::make_pair(binding->get<uint32_t>(), global.value("set", uint32_t{0}));
       }},
  };
  return rows;
}

BindingOptions read_bindings(Reading& r, const json& value, const std::string& what) {
  BindingOptions out;
  if (!value.is_object()) r.fields.fail("bindings", "\"bindings\" of " + what + " must be an object");
  else read_fields(r, value, binding_fields(), "\"bindings\"", out);
  return out;
}

// "defines": {"NAME": "value" | integer | true | false}
std::vector<Define> read_defines(Reading& r, const json& value, const std::string& what) {
  std::vector<Define> out;
  if (!value.is_object()) {
    r.fields.fail("defines", "\"defines\" of " + what + " must be an object: name -> value");
    return out;
  }
  for (auto& [name, item] : value.items()) {
    Define define{name, "1"};
    if (item.is_string()) define.value = item.get<std::string>();
    else if (item.is_number_integer()) define.value = item.dump();
    else if (item.is_boolean()) define.value = item.get<bool>() ? "1" : "0";
    else r.fields.fail(name, "define '" + name + "' must have a string, integer or boolean value");
    if (std::string problem = define_problem(define); !problem.empty()) r.fields.fail(name, "define: " + problem);
    out.push_back(std::move(define));
  }
  return out;
}

// A "targets" list (the pack's, or a pass's own): known names, SPIR-V always in (every other target is made from
// it), sorted.
std::vector<Target> read_targets(Reading& r, const json& value) {
  std::vector<Target> targets;
  for (const std::string& name : strings_field(r, "targets", value)) {
    if (auto target = parse_target(name)) {
      if (std::find(targets.begin(), targets.end(), *target) == targets.end()) targets.push_back(*target);
    } else {
      r.fields.fail(name, "unknown target '" + name + "' (expected " + target_name_list() + ")");
    }
  }
  if (std::find(targets.begin(), targets.end(), Target::Spirv) == targets.end()) targets.insert(targets.begin(), Target::Spirv);
  std::sort(targets.begin(), targets.end());
  return targets;
}

// A stage names its entry point in the pass's source ("vertex": "VSMain"), or a file of its own with its entry point
// ("vertex": {"source": "Sky.vert.hlsl", "entry": "main"}), as stage-per-file projects write them, with "bindings"
// of its own over the pass's.
struct StageReading {
  std::optional<std::string> source, entry;
  std::optional<BindingOptions> bindings;
  std::string what;  // "stage 'vertex' of pass 'Forward'"
};

const std::vector<Field<StageReading>>& stage_fields() {
  static const std::vector<Field<StageReading>> rows{
      {"source", [](Reading& r, const json& value, StageReading& out) { out.source = string_field(r, "source", value); }, true},
      {"entry", [](Reading& r, const json& value, StageReading& out) { out.entry = string_field(r, "entry", value); }},
      {"bindings", [](Reading& r, const json& value, StageReading& out) { out.bindings = read_bindings(r, value, out.what); }},
  };
  return rows;
}

struct PackReading {
  PackDefinition pack;
  std::optional<std::string> shader;  // the passes' default "source"
};

struct PassReading {
  const PackReading& pack;
  PassDefinition pass;
  std::array<std::optional<BindingOptions>, kStageCount> own_bindings;
  bool has_stages = false;
  bool usable = true;  // false: its "stages" could not be read; it is not added (the load fails anyway)
};

void read_stages(Reading& r, const json& stages, PassReading& p) {
  PassDefinition& pass = p.pass;
  p.has_stages = true;
  if (!stages.is_object() || stages.empty()) {
    p.usable = false;
    return;  // the pass's finish says what "stages" must be
  }
  for (auto& [stage_text, value] : stages.items()) {
    const std::optional<Stage> stage = parse_stage(stage_text);
    std::string entry;
    std::optional<std::string> own_source;
    if (value.is_object()) {
      StageReading own;
      own.what = "stage '" + stage_text + "' of pass '" + pass.name + "'";
      read_fields(r, value, stage_fields(), "a stage", own);
      own_source = own.source;
      entry = own.entry.value_or("main");
      if (!own.entry && stage) pass.default_entries |= stage_bit(*stage);
      if (stage && own.bindings) p.own_bindings[static_cast<size_t>(*stage)] = own.bindings;
    } else if (value.is_string()) {
      entry = value.get<std::string>();
    }
    if (!stage) {
      std::string names;
      for (const StageName& known : kStageNames) names += (names.empty() ? "" : ", ") + std::string(known.name);
      r.fields.fail(stage_text, "unknown stage '" + stage_text + "' (expected one of " + names + ")");
    } else if (entry.empty()) {
      r.fields.fail(stage_text, "stage '" + stage_text + "' must name an entry point, or {\"source\": FILE, \"entry\": NAME}");
    } else if (!own_source && pass.source.empty()) {
      r.fields.fail(pass.name, "pass '" + pass.name + "' has no \"source\" (and the pack no \"shader\") for its " + stage_text +
                                   " stage: give the pass one, or the stage {\"source\": FILE, \"entry\": NAME}");
    } else {
      pass.entry_points[static_cast<size_t>(*stage)] = entry;
      pass.stage_sources[static_cast<size_t>(*stage)] = own_source ? r.base / *own_source : pass.source;
    }
  }
}

const std::vector<Field<PassReading>>& pass_fields() {
  static const std::vector<Field<PassReading>> rows{
      {"name",
       [](Reading& r, const json& value, PassReading& p) {
         p.pass.name = string_field(r, "name", value).value_or("");
         if (value.is_string())
           if (std::string problem = name_problem(p.pass.name); !problem.empty())
             r.fields.fail(p.pass.name,
                           "pass name '" + echoed(p.pass.name) + "' " + problem + " (it names the pass's --emit directory)");
       },
       true},
      {"description"},
      {"source",
       [](Reading& r, const json& value, PassReading& p) {
         if (auto source = string_field(r, "source", value)) p.pass.source = r.base / *source;
       }},
      // No "stages": the entry points come from the source's Unity pragmas (`#pragma vertex vert`), which the
      // declaration scan reads (apply_stage_pragmas); a pass with neither is an error (its finish).
      {"stages", read_stages},
      {"targets", [](Reading& r, const json& value, PassReading& p) { p.pass.targets = read_targets(r, value); }},  // instead of the pack's
      {"bindings",
       [](Reading& r, const json& value, PassReading& p) {
         p.pass.bindings.override_with(read_bindings(r, value, "pass '" + p.pass.name + "'"));
       }},
      {"defines",
       [](Reading& r, const json& value, PassReading& p) {
         for (Define& define : read_defines(r, value, "pass '" + p.pass.name + "'")) {
           std::erase_if(p.pass.defines, [&](const Define& d) { return d.name == define.name; });  // the pass's value wins
           p.pass.defines.push_back(std::move(define));
         }
       }},
  };
  return rows;
}

void read_pass(Reading& r, const json& item, PackReading& p) {
  PassReading reading{p, {}, {}};
  PassDefinition& pass = reading.pass;
  if (p.shader) pass.source = r.base / *p.shader;
  pass.bindings = p.pack.bindings;
  pass.defines = p.pack.defines;
  pass.name = item.contains("name") && item["name"].is_string() ? item["name"].get<std::string>() : "";
  read_fields(r, item, pass_fields(), "a pass", reading);
  pass.defined_at = r.fields.at(pass.name);
  if (!reading.usable || (!reading.has_stages && pass.source.empty())) {
    r.fields.fail(pass.name, "pass '" + pass.name + "' needs \"stages\": {\"vertex\": \"Entry\", \"fragment\": \"Entry\"}" +
                                 (pass.source.empty() ? std::string() : ", or no \"stages\" to take them from '#pragma vertex NAME' and '#pragma fragment NAME' in its source"));
    return;
  }
  for (size_t s = 0; s < kStageCount; ++s)
    if (reading.own_bindings[s]) {
      pass.stage_bindings[s] = pass.bindings;
      pass.stage_bindings[s]->override_with(*reading.own_bindings[s]);
    }
  for (const PassDefinition& other : p.pack.passes)
    if (other.name == pass.name) r.fields.fail(pass.name, "pass '" + pass.name + "' is defined twice");
  p.pack.passes.push_back(std::move(pass));
}

const std::vector<Field<Constraint>>& constraint_fields() {
  static const std::vector<Field<Constraint>> rows{
      {"keyword",
       [](Reading& r, const json& value, Constraint& c) {
         c.keyword = string_field(r, "keyword", value).value_or("");
       },
       true},
      {"requires", [](Reading& r, const json& value, Constraint& c) { c.requires_all = strings_field(r, "requires", value); }},
      {"requires_any", [](Reading& r, const json& value, Constraint& c) { c.requires_any = strings_field(r, "requires_any", value); }},
      {"excludes", [](Reading& r, const json& value, Constraint& c) { c.excludes = strings_field(r, "excludes", value); }},
      {"reason", [](Reading& r, const json& value, Constraint& c) { c.reason = string_field(r, "reason", value).value_or(""); }},
  };
  return rows;
}

const std::vector<Field<MaterialPreset>>& material_fields() {
  static const std::vector<Field<MaterialPreset>> rows{
      {"name",
       [](Reading& r, const json& value, MaterialPreset& m) {
         m.name = string_field(r, "name", value).value_or("");
       },
       true},
      {"description"},
      {"keywords",
       [](Reading& r, const json& value, MaterialPreset& m) {
         for (const std::string& k : strings_field(r, "keywords", value)) m.keywords.insert(k);
       }},
  };
  return rows;
}

const std::vector<Field<PackDefinition>>& lint_fields() {
  static const std::vector<Field<PackDefinition>> rows{
      {"disable",
       [](Reading& r, const json& value, PackDefinition& pack) {
         const std::vector<std::string> rule_ids(kRuleIdTexts.begin(), kRuleIdTexts.end());
         for (const std::string& rule : strings_field(r, "disable", value)) {
           if (parse_rule_id(rule)) {
             pack.lint_disable.push_back(rule);
             continue;
           }
           // A misspelt rule would silently disable nothing.
           const std::optional<std::string> suggestion = closest_match(rule, rule_ids);
           const bool printable = rule.size() <= 64 && std::all_of(rule.begin(), rule.end(), [](char c) {
             return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '_';
           });  // a name from the file is quoted only when it cannot carry a control sequence
           r.fields.fail(rule, "unknown lint rule" + (printable ? " '" + rule + "'" : std::string()) + " in \"lint\": \"disable\"" +
                                   (suggestion ? " (did you mean '" + *suggestion + "'?)" : " (the rules are in docs/lint.md)"));
         }
       }},
  };
  return rows;
}

void read_keyword_kinds(Reading& r, const json& kinds, PackReading& p) {
  if (!kinds.is_object()) {
    r.fields.fail("keyword_kinds", "\"keyword_kinds\" must be an object: keyword -> " + keyword_kind_list("\""));
    return;
  }
  for (auto& [keyword, value] : kinds.items()) {
    const std::optional<KeywordKind> kind = parse_keyword_kind(value.is_string() ? value.get<std::string>() : "");
    if (!kind) r.fields.fail(keyword, "the kind of keyword '" + keyword + "' must be " + keyword_kind_list("\""));
    if (!is_identifier(keyword)) r.fields.fail(keyword, "'" + keyword + "' is not a valid keyword name");
    p.pack.keyword_kinds[keyword] = PackDefinition::KindOverride{kind.value_or(KeywordKind::Variant), r.fields.at(keyword)};
  }
}

const std::vector<Field<PackReading>>& pack_fields() {
  static const std::vector<Field<PackReading>> rows{
      {"$schema"},
      {"name",
       [](Reading& r, const json& value, PackReading& p) {
         if (auto name = string_field(r, "name", value)) {
           p.pack.name = *name;
           if (std::string problem = name_problem(p.pack.name); !problem.empty())
             r.fields.fail("name", "pack name '" + echoed(p.pack.name) + "' " + problem);
         }
       },
       true},
      {"description"},
      {"shader", [](Reading& r, const json& value, PackReading& p) { p.shader = string_field(r, "shader", value); }},
      {"include_dirs",
       [](Reading& r, const json& value, PackReading& p) {
         for (const std::string& dir : strings_field(r, "include_dirs", value)) p.pack.include_dirs.push_back(r.base / dir);
       }},
      {"targets", [](Reading& r, const json& value, PackReading& p) { p.pack.targets = read_targets(r, value); }},
      {"budget",
       [](Reading& r, const json& value, PackReading& p) {
         if (!value.is_number_unsigned() || value.get<uint64_t>() == 0) r.fields.fail("budget", "\"budget\" must be a positive integer");
         else p.pack.budget = value.get<uint64_t>();
       }},
      {"bindings", [](Reading& r, const json& value, PackReading& p) { p.pack.bindings = read_bindings(r, value, "the pack"); }},
      {"defines", [](Reading& r, const json& value, PackReading& p) { p.pack.defines = read_defines(r, value, "the pack"); }},
      // After "shader", "bindings" and "defines": each pass starts from them.
      {"passes",
       [](Reading& r, const json& value, PackReading& p) {
         if (!value.is_array() || value.empty()) r.fields.fail("passes", "\"passes\" must be a non-empty array");
         else for_each_object(r, "passes", value, "pass", [&](const json& item) { read_pass(r, item, p); });
       },
       true, "\"passes\" must be a non-empty array"},
      {"constraints",
       [](Reading& r, const json& value, PackReading& p) {
         for_each_object(r, "constraints", value, "constraint", [&](const json& item) {
           Constraint constraint;
           read_fields(r, item, constraint_fields(), "a constraint", constraint);
           constraint.defined_at = r.fields.at(constraint.keyword);
           if (constraint.requires_all.empty() && constraint.requires_any.empty() && constraint.excludes.empty())
             r.fields.fail(constraint.keyword,
                           "constraint on '" + constraint.keyword + "' needs \"requires\", \"requires_any\" or \"excludes\"");
           p.pack.constraints.push_back(std::move(constraint));
         });
       }},
      {"materials",
       [](Reading& r, const json& value, PackReading& p) {
         for_each_object(r, "materials", value, "material", [&](const json& item) {
           MaterialPreset material;
           read_fields(r, item, material_fields(), "a material preset", material);
           material.defined_at = r.fields.at(material.name);
           p.pack.materials.push_back(std::move(material));
         });
       }},
      {"scene_features",
       [](Reading& r, const json& value, PackReading& p) {
         if (!value.is_object()) r.fields.fail("scene_features", "\"scene_features\" must be an object: feature -> value -> keywords");
         else p.pack.scene_features_json = value.dump();
       }},
      {"keyword_kinds", read_keyword_kinds},
      {"lint",
       [](Reading& r, const json& value, PackReading& p) {
         if (!value.is_object()) r.fields.fail("lint", "\"lint\" must be an object: {\"disable\": [\"rule-id\", ...]}");
         else read_fields(r, value, lint_fields(), "\"lint\"", p.pack);
       }},
  };
  return rows;
}

struct SceneReading {
  SceneProfile scene;
  bool selects = false;  // it has "uses", "materials" or "keywords"
};

const std::vector<Field<SceneReading>>& scene_fields() {
  static const std::vector<Field<SceneReading>> rows{
      {"$schema"},
      {"name",
       [](Reading& r, const json& value, SceneReading& s) {
         if (auto name = string_field(r, "name", value)) {
           s.scene.name = *name;
           if (std::string problem = name_problem(s.scene.name); !problem.empty())
             r.fields.fail("name", "scene name '" + echoed(s.scene.name) + "' " + problem);
         }
       },
       true},
      {"description"},
      {"uses",
       [](Reading& r, const json& value, SceneReading& s) {
         s.selects = true;
         if (!value.is_object()) r.fields.fail("uses", "\"uses\" must be an object: feature -> value");
         else s.scene.uses_json = value.dump();
       }},
      {"materials",
       [](Reading& r, const json& value, SceneReading& s) {
         s.selects = true;
         s.scene.material_names = strings_field(r, "materials", value);
       }},
      {"keywords",
       [](Reading& r, const json& value, SceneReading& s) {
         s.selects = true;
         for (const std::string& keyword : strings_field(r, "keywords", value)) s.scene.keywords.insert(keyword);
       }},
  };
  return rows;
}

}  // namespace

const DefinitionFields& definition_fields() {
  static const DefinitionFields fields{
      names_of(pack_fields()),     names_of(pass_fields()),  names_of(constraint_fields()), names_of(material_fields()),
      names_of(scene_fields()),    names_of(binding_fields()), names_of(shift_fields()),    names_of(lint_fields()),
      names_of(stage_fields()),
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
  Reading reading{fields, file.parent_path().empty() ? "." : file.parent_path()};
  PackReading p;
  p.pack.file = file;
  p.pack.text = *text;
  for (const TargetName& target : kTargetNames) p.pack.targets.push_back(target.target);  // without "targets": all
  read_fields(reading, *root, pack_fields(), "the pack definition", p);
  if (!fields.ok) return std::nullopt;
  return std::move(p.pack);
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
  Reading reading{fields, file.parent_path()};
  SceneReading s;
  s.scene.file = file;
  s.scene.text = *text;
  read_fields(reading, *root, scene_fields(), "the scene profile", s);
  if (!s.selects) fields.fail("name", "a scene profile needs \"uses\", \"materials\" or \"keywords\"");
  if (!fields.ok) return std::nullopt;
  return std::move(s.scene);
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
                  "--keyword-kind '" + text + "': expected KEYWORD[,KEYWORD...]=KIND, the kind " + keyword_kind_list());
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
