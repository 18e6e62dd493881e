// SPDX-License-Identifier: Apache-2.0
#include "kiln/manifest_json.hpp"

#include <algorithm>
#include <limits>
#include <tuple>
#include <type_traits>

#include "kiln/folded_keywords.hpp"
#include "kiln/pack_format.hpp"

namespace kiln {

using nlohmann::json;

ManifestError::ManifestError(std::string where, std::string what)
    : std::runtime_error((where.empty() ? std::string("top level") : where) + ": " + what),
      where_(std::move(where)),
      what_(std::move(what)) {}

ManifestError ManifestError::inside(std::string_view parent) const { return {std::string(parent) + where_, what_}; }

namespace {

// ---- Names ------------------------------------------------------------------------------------------------------

constexpr std::array<std::string_view, 9> kResourceKindNames{
    "uniform_buffer",       "storage_buffer",       "texture",         "sampler", "combined_image_sampler", "storage_image",
    "uniform_texel_buffer", "storage_texel_buffer", "input_attachment"};
constexpr std::array<std::string_view, 3> kMslKindNames{"buffer", "texture", "sampler"};

template <class Enum, size_t N>
std::optional<Enum> parse_name(const std::array<std::string_view, N>& names, std::string_view name) {
  for (size_t i = 0; i < N; ++i)
    if (names[i] == name) return static_cast<Enum>(i);
  return std::nullopt;
}

// ---- Reading: each reader throws ManifestError with the place relative to the value it reads ----------------

[[noreturn]] void fail(const std::string& what) { throw ManifestError("", what); }

template <class F>
void inside(const std::string& step, F&& read) {
  try {
    read();
  } catch (const ManifestError& error) {
    throw error.inside("/" + step);
  }
}

void read_value(const json& v, std::string& out) {
  if (!v.is_string()) fail("is not a string");
  out = v.get<std::string>();
}

void read_value(const json& v, bool& out) {
  if (!v.is_boolean()) fail("is not a boolean");
  out = v.get<bool>();
}

template <class T>
  requires std::is_unsigned_v<T> && (!std::is_same_v<T, bool>)
void read_value(const json& v, T& out) {
  if (!v.is_number_unsigned()) fail("is not an unsigned integer");
  const uint64_t value = v.get<uint64_t>();
  if (value > std::numeric_limits<T>::max()) fail(v.dump() + " is out of range");
  out = static_cast<T>(value);
}

// A name among an enumeration's; `parse` is its parser, `what` says what it is ("a stage").
template <class Enum, class Parse>
void read_name(const json& v, Enum& out, Parse parse, const char* what) {
  std::string name;
  read_value(v, name);
  std::optional<Enum> value = parse(name);
  if (!value) fail(json(name).dump() + " is not " + what);
  out = *value;
}

void read_value(const json& v, Stage& out) { read_name(v, out, parse_stage, "a stage"); }
void read_value(const json& v, Target& out) { read_name(v, out, parse_target, "a target"); }
void read_value(const json& v, ResourceKind& out) { read_name(v, out, parse_resource_kind, "a resource kind"); }
void read_value(const json& v, MslResourceKind& out) {
  read_name(v, out, [](std::string_view name) { return parse_name<MslResourceKind>(kMslKindNames, name); }, "an MSL resource kind");
}

// The manifest's structs: their own from_json.
template <class T>
  requires std::is_class_v<T>
void read_value(const json& v, T& out) {
  from_json(v, out);
}

template <class T>
void read_value(const json& v, std::vector<T>& out) {
  if (!v.is_array()) fail("is not an array");
  out.assign(v.size(), T{});
  for (size_t i = 0; i < v.size(); ++i) inside(std::to_string(i), [&] { read_value(v[i], out[i]); });
}

void read_value(const json& v, std::array<uint32_t, 3>& out) {
  if (!v.is_array() || v.size() != 3) fail("is not an array of 3 numbers");
  for (size_t i = 0; i < 3; ++i) inside(std::to_string(i), [&] { read_value(v[i], out[i]); });
}

void read_value(const json& v, std::set<std::string>& out) {
  std::vector<std::string> list;
  read_value(v, list);
  out = {list.begin(), list.end()};
}

template <class T>
void read_value(const json& v, std::optional<T>& out) {
  out.emplace();
  read_value(v, *out);
}

// An object keyed by stage or target names ("vertex": ..., "spirv": ...), or by any string.
template <class Key, class T>
void read_value(const json& v, std::map<Key, T>& out) {
  if (!v.is_object()) fail("is not an object");
  out.clear();
  for (auto it = v.begin(); it != v.end(); ++it) {
    const std::string& name = it.key();
    inside(name, [&] {
      Key key{};
      if constexpr (std::is_same_v<Key, std::string>) key = name;
      else read_value(json(name), key);
      read_value(it.value(), out[key]);
    });
  }
}

const json& member(const json& object, const char* key) {
  if (!object.is_object()) fail("is not an object");
  auto it = object.find(key);
  if (it == object.end()) fail(std::string("has no \"") + key + "\"");
  return *it;
}

template <class T>
void read(const json& object, const char* key, T& out) {
  const json& value = member(object, key);
  inside(key, [&] { read_value(value, out); });
}

// A field kiln writes only when it has something to say; absent, `out` keeps its default.
template <class T>
void read_if_present(const json& object, const char* key, T& out) {
  if (!object.is_object()) fail("is not an object");
  if (object.contains(key)) read(object, key, out);
}

// ---- Writing: the value kiln writes for each type --------------------------------------------------------------

json write_value(const std::string& v) { return v; }
json write_value(bool v) { return v; }
template <class T>
  requires std::is_unsigned_v<T> && (!std::is_same_v<T, bool>)
json write_value(T v) {
  return v;
}
json write_value(Stage v) { return stage_name(v); }
json write_value(Target v) { return target_name(v); }
json write_value(ResourceKind v) { return kResourceKindNames[static_cast<size_t>(v)]; }
json write_value(MslResourceKind v) { return kMslKindNames[static_cast<size_t>(v)]; }
json write_value(const std::array<uint32_t, 3>& v) { return v; }
json write_value(const std::set<std::string>& v) { return v; }
// The manifest's structs: their own to_json (a field table's, or one of their own).
template <class T>
  requires std::is_class_v<T>
json write_value(const T& v) {
  return json(v);
}
template <class T>
json write_value(const std::optional<T>& v) {
  return write_value(*v);
}
template <class T>
json write_value(const std::vector<T>& v) {
  json out = json::array();
  for (const T& item : v) out.push_back(write_value(item));
  return out;
}
// An object keyed by stage or target names ("vertex": ..., "spirv": ...), or by any string.
template <class Key, class T>
json write_value(const std::map<Key, T>& map) {
  json out = json::object();
  for (const auto& [key, value] : map) {
    if constexpr (std::is_same_v<Key, std::string>) out[key] = write_value(value);
    else out[write_value(key).template get<std::string>()] = write_value(value);
  }
  return out;
}

// Whether a field written only when set has something to say: true, an engaged optional, a non-empty string or list.
template <class T>
bool is_set(const T& v) {
  if constexpr (std::is_same_v<T, bool>) return v;
  else if constexpr (requires { v.has_value(); }) return v.has_value();
  else if constexpr (requires { v.empty(); }) return !v.empty();
  else return true;  // a number or a struct: always something to say
}

// ---- Field tables: each struct's fields, stated once, for writing and for reading ---------------------------------
//
// A field is written under its name and read from it (errors name it in their JSON pointer). Always: written, and
// required. WhenSet: written only when it has something to say (true, a non-empty string or list, an engaged
// optional), read when present. A field may also apply only to some values of its struct (a block's members, an
// image's dimension): `applies`, asked of the struct as read so far, so a field it depends on comes first.

enum class When { Always, WhenSet };

template <class S, class T>
struct Field {
  const char* name;
  T S::*member;
  When when = When::Always;
  bool (*applies)(const S&) = nullptr;
};
template <class S, class T>
constexpr Field<S, T> always(const char* name, T S::*member, bool (*applies)(const S&) = nullptr) {
  return {name, member, When::Always, applies};
}
template <class S, class T>
constexpr Field<S, T> when_set(const char* name, T S::*member, bool (*applies)(const S&) = nullptr) {
  return {name, member, When::WhenSet, applies};
}

// Fields<S>::list: S's fields, in the order they are read (a reader's first error is the first field's).
template <class S>
struct Fields;

template <class S>
void write_fields(json& j, const S& v) {
  if (!j.is_object()) j = json::object();
  std::apply(
      [&](const auto&... field) {
        auto write_one = [&](const auto& f) {
          if (f.applies && !f.applies(v)) return;
          if (f.when == When::WhenSet && !is_set(v.*f.member)) return;
          j[f.name] = write_value(v.*f.member);
        };
        (write_one(field), ...);
      },
      Fields<S>::list);
}

template <class S>
void read_fields(const json& j, S& v) {
  std::apply(
      [&](const auto&... field) {
        auto read_one = [&](const auto& f) {
          if (f.applies && !f.applies(v)) return;
          if (f.when == When::WhenSet) read_if_present(j, f.name, v.*f.member);
          else read(j, f.name, v.*f.member);
        };
        (read_one(field), ...);
      },
      Fields<S>::list);
}

constexpr bool block_resource(const Resource& r) { return is_block(r.kind); }
constexpr bool image_resource(const Resource& r) { return is_image(r.kind); }
constexpr bool input_attachment(const Resource& r) { return r.kind == ResourceKind::InputAttachment; }

template <>
struct Fields<BlockMember> {
  static constexpr auto list = std::tuple{always("name", &BlockMember::name), always("offset", &BlockMember::offset),
                                          always("size", &BlockMember::size), always("type", &BlockMember::type),
                                          when_set("array_stride", &BlockMember::array_stride)};
};
template <>
struct Fields<Resource> {
  static constexpr auto list =
      std::tuple{always("name", &Resource::name),      always("kind", &Resource::kind),
                 always("set", &Resource::set),        always("binding", &Resource::binding),
                 always("count", &Resource::count),    always("size", &Resource::size, block_resource),
                 always("members", &Resource::members, block_resource),
                 always("dimension", &Resource::dimension, image_resource),
                 when_set("depth", &Resource::depth, image_resource),
                 always("input_attachment_index", &Resource::input_attachment_index, input_attachment)};
};
template <>
struct Fields<PushConstantBlock> {
  static constexpr auto list = std::tuple{always("name", &PushConstantBlock::name), always("size", &PushConstantBlock::size),
                                          always("members", &PushConstantBlock::members)};
};
template <>
struct Fields<StageVariable> {
  static constexpr auto list = std::tuple{always("name", &StageVariable::name), always("location", &StageVariable::location),
                                          always("type", &StageVariable::type), when_set("semantic", &StageVariable::semantic)};
};
template <>
struct Fields<GlCombinedSampler> {
  static constexpr auto list = std::tuple{always("name", &GlCombinedSampler::name), always("texture", &GlCombinedSampler::texture),
                                          always("sampler", &GlCombinedSampler::sampler), always("binding", &GlCombinedSampler::binding)};
};
template <>
struct Fields<GlBlock> {
  static constexpr auto list = std::tuple{always("name", &GlBlock::name), always("kind", &GlBlock::kind),
                                          always("binding", &GlBlock::binding)};
};
template <>
struct Fields<GlBindings> {
  static constexpr auto list = std::tuple{always("combined_image_samplers", &GlBindings::combined_image_samplers),
                                          always("blocks", &GlBindings::blocks)};
};
template <>
struct Fields<MslResource> {
  static constexpr auto list = std::tuple{always("name", &MslResource::name), always("kind", &MslResource::kind),
                                          always("index", &MslResource::index)};
};
template <>
struct Fields<MslBindings> {
  static constexpr auto list = std::tuple{always("resources", &MslBindings::resources)};
};
// Each target's own binding records under the target's name (kiln/targets.def).
template <>
struct Fields<Reflection> {
  static constexpr auto list =
      std::tuple{always("resources", &Reflection::resources), always("push_constants", &Reflection::push_constants),
                 always("inputs", &Reflection::inputs),       always("outputs", &Reflection::outputs),
                 when_set("local_size", &Reflection::local_size), when_set("glsl", &Reflection::glsl),
                 when_set("gles", &Reflection::gles),         when_set("msl", &Reflection::msl)};
};
template <>
struct Fields<PassLayout> {
  static constexpr auto list = std::tuple{always("resources", &PassLayout::resources), always("push_constants", &PassLayout::push_constants)};
};
template <>
struct Fields<ManifestVariant> {
  static constexpr auto list = std::tuple{always("keywords", &ManifestVariant::keywords), always("binaries", &ManifestVariant::binaries)};
};
template <>
struct Fields<ManifestPass> {
  static constexpr auto list =
      std::tuple{always("name", &ManifestPass::name),         always("stages", &ManifestPass::entry_points),
                 always("keyword_groups", &ManifestPass::keyword_groups), always("layout", &ManifestPass::layout),
                 always("variants", &ManifestPass::variants), when_set("bindings", &ManifestPass::bindings),
                 when_set("defines", &ManifestPass::defines), when_set("targets", &ManifestPass::targets)};
};
template <>
struct Fields<ManifestBinary> {
  static constexpr auto list = std::tuple{always("stage", &ManifestBinary::stage), always("entry", &ManifestBinary::entry),
                                          always("blobs", &ManifestBinary::blobs), always("reflection", &ManifestBinary::reflection)};
};
template <>
struct Fields<ManifestConstraint> {
  static constexpr auto list =
      std::tuple{always("keyword", &ManifestConstraint::keyword), when_set("requires", &ManifestConstraint::requires_all),
                 when_set("requires_any", &ManifestConstraint::requires_any),
                 when_set("excludes", &ManifestConstraint::excludes), when_set("reason", &ManifestConstraint::reason)};
};
template <>
struct Fields<ManifestMaterial> {
  static constexpr auto list = std::tuple{always("name", &ManifestMaterial::name), always("keywords", &ManifestMaterial::keywords)};
};
template <>
struct Fields<ManifestTools> {
  static constexpr auto list = std::tuple{always("frontend", &ManifestTools::frontend), always("spirv_tools", &ManifestTools::spirv_tools),
                                          always("spirv_cross", &ManifestTools::spirv_cross)};
};
template <>
struct Fields<ManifestOptions> {
  static constexpr auto list =
      std::tuple{always("optimize", &ManifestOptions::optimize),     always("optimizer_recipe", &ManifestOptions::optimizer_recipe),
                 always("targets", &ManifestOptions::targets),       always("spirv_env", &ManifestOptions::spirv_env),
                 always("glsl_version", &ManifestOptions::glsl_version), always("gles_version", &ManifestOptions::gles_version),
                 always("msl_version", &ManifestOptions::msl_version),
                 always("gl_clip_space_fixup", &ManifestOptions::gl_clip_space_fixup)};
};
template <>
struct Fields<ManifestFunnel> {
  static constexpr auto list =
      std::tuple{always("declared", &ManifestFunnel::declared),
                 always("valid", &ManifestFunnel::valid),
                 always("kept", &ManifestFunnel::kept),
                 always("stage_instances", &ManifestFunnel::stage_instances),
                 always("unique_preprocessed", &ManifestFunnel::unique_preprocessed),
                 always("unique_compiles", &ManifestFunnel::unique_compiles),
                 always("unique_modules", &ManifestFunnel::unique_modules),
                 always("unique_binaries", &ManifestFunnel::unique_binaries)};
};
template <>
struct Fields<ManifestArchive> {
  static constexpr auto list = std::tuple{always("file", &ManifestArchive::file), always("size", &ManifestArchive::size),
                                          always("xxh3_64", &ManifestArchive::xxh3_64), always("blobs", &ManifestArchive::blobs)};
};
// The fields a reader needs first (the name, the archive, the records selection reads), then the rest. "format" and
// "scene_features" are Manifest's to_json and from_json's own.
template <>
struct Fields<Manifest> {
  static constexpr auto list =
      std::tuple{always("format_version", &Manifest::format_version), always("name", &Manifest::name),
                 always("archive", &Manifest::archive),               always("binaries", &Manifest::binaries),
                 always("reflections", &Manifest::reflections),       always("passes", &Manifest::passes),
                 always("kiln_version", &Manifest::kiln_version),     always("tools", &Manifest::tools),
                 always("options", &Manifest::options),               always("inputs_hash", &Manifest::inputs_hash),
                 always("funnel", &Manifest::funnel),                 always("constraints", &Manifest::constraints),
                 always("materials", &Manifest::materials)};
};

}  // namespace

std::string_view resource_kind_name(ResourceKind kind) { return kResourceKindNames[static_cast<size_t>(kind)]; }

std::optional<ResourceKind> parse_resource_kind(std::string_view name) {
  return parse_name<ResourceKind>(kResourceKindNames, name);
}

// ---- The manifest's types: their field tables, and what a table cannot say ------------------------------------

#define KILN_FIELD_TABLE_JSON(Type)                                            \
  void to_json(json& j, const Type& v) { write_fields(j, v); }                  \
  void from_json(const json& j, Type& v) { read_fields(j, v); }
KILN_FIELD_TABLE_JSON(BlockMember)
KILN_FIELD_TABLE_JSON(Resource)
KILN_FIELD_TABLE_JSON(PushConstantBlock)
KILN_FIELD_TABLE_JSON(StageVariable)
KILN_FIELD_TABLE_JSON(GlCombinedSampler)
KILN_FIELD_TABLE_JSON(GlBindings)
KILN_FIELD_TABLE_JSON(MslResource)
KILN_FIELD_TABLE_JSON(MslBindings)
KILN_FIELD_TABLE_JSON(PassLayout)
KILN_FIELD_TABLE_JSON(ManifestVariant)
KILN_FIELD_TABLE_JSON(ManifestPass)
KILN_FIELD_TABLE_JSON(ManifestBinary)
KILN_FIELD_TABLE_JSON(ManifestConstraint)
KILN_FIELD_TABLE_JSON(ManifestMaterial)
KILN_FIELD_TABLE_JSON(ManifestTools)
KILN_FIELD_TABLE_JSON(ManifestOptions)
KILN_FIELD_TABLE_JSON(ManifestFunnel)
KILN_FIELD_TABLE_JSON(ManifestArchive)
#undef KILN_FIELD_TABLE_JSON

void to_json(json& j, const GlBlock& v) { write_fields(j, v); }
void from_json(const json& j, GlBlock& v) {
  read_fields(j, v);
  if (!is_block(v.kind)) throw ManifestError("/kind", "is not a block kind");
}

void to_json(json& j, const Reflection& v) { write_fields(j, v); }
void from_json(const json& j, Reflection& v) {
  read_fields(j, v);
  if (v.local_size && ((*v.local_size)[0] == 0 || (*v.local_size)[1] == 0 || (*v.local_size)[2] == 0))
    throw ManifestError("/local_size", "has a thread-group size of 0");
}

bool Reflection::holds(const Resource& resource) const {
  return std::find(resources.begin(), resources.end(), resource) != resources.end();
}

// A group's off value is "" in the model and "_" in the file; its stages are a mask in the model, names in the file
// (absent: every stage, as manifests before stage masks were written).
void to_json(json& j, const ManifestKeywordGroup& v) {
  json values = json::array();
  for (const std::string& value : v.values) values.push_back(value.empty() ? "_" : value);
  json stages = json::array();
  for (Stage s : kAllStages)
    if (v.stages & stage_bit(s)) stages.push_back(stage_name(s));
  j = {{"pragma", v.pragma}, {"values", values}, {"stages", stages}};
}
void from_json(const json& j, ManifestKeywordGroup& v) {
  read(j, "pragma", v.pragma);
  read(j, "values", v.values);
  for (std::string& value : v.values)
    if (value == "_") value.clear();
  if (j.contains("stages")) {
    std::vector<Stage> stages;
    read(j, "stages", stages);
    v.stages = 0;
    for (Stage s : stages) v.stages |= stage_bit(s);
  }
}

namespace {

// A pass's folded keywords (kiln/folded_keywords.hpp), for people and tools that read the JSON: where each lives.
// They follow from the keyword groups; a reader recomputes them and refuses a manifest whose record disagrees.
json folded_keywords_record(const ManifestPass& pass) {
  json out = json::array();
  for (const FoldedKeyword& k : folded_keywords(pass.keyword_groups)) {
    json stages = json::array();
    for (Stage s : kAllStages)
      if (k.stages & stage_bit(s)) stages.push_back(stage_name(s));
    json entry = {{"keyword", k.keyword}, {"kind", keyword_kind_name(k.kind)}, {"stages", stages}, {"type", "bool"}, {"default", false}};
    if (k.kind == KeywordKind::SpecializationInteger) {
      entry["keyword"] = k.keyword.empty() ? "_" : k.keyword;
      entry["type"] = "int";
      entry["default"] = k.fallback;
      entry["constant_id"] = k.slot;
      entry["value"] = k.value;
    } else if (k.kind == KeywordKind::SpecializationConstant) {
      entry["constant_id"] = k.slot;
    } else {
      entry["block"] = kKeywordBlockName;
      entry["set"] = kKeywordBlockSet;
      entry["binding"] = kKeywordBlockBinding;
      entry["offset"] = k.slot;
    }
    out.push_back(std::move(entry));
  }
  return out;
}

}  // namespace

void to_json(json& j, const Manifest& v) {
  write_fields(j, v);
  j["format"] = kManifestFormat;
  j["scene_features"] = json::parse(v.scene_features_json);
  for (size_t p = 0; p < v.passes.size(); ++p)
    if (json folded = folded_keywords_record(v.passes[p]); !folded.empty()) j["passes"][p]["folded_keywords"] = std::move(folded);
}
void from_json(const json& j, Manifest& v) {
  read_fields(j, v);
  const json& scene_features = member(j, "scene_features");
  if (!scene_features.is_object()) throw ManifestError("/scene_features", "is not an object");
  v.scene_features_json = scene_features.dump();
  for (size_t p = 0; p < v.passes.size(); ++p) {
    const json& pass = j.at("passes").at(p);
    const json expected = folded_keywords_record(v.passes[p]);
    const auto it = pass.find("folded_keywords");
    if (it == pass.end() ? !expected.empty() : *it != expected)
      throw ManifestError("/passes/" + std::to_string(p) + "/folded_keywords",
                          "does not match the pass's keyword groups (kiln/folded_keywords.hpp)");
  }
}

const ManifestPass* Manifest::pass(std::string_view pass_name) const {
  for (const ManifestPass& p : passes)
    if (p.name == pass_name) return &p;
  return nullptr;
}

void Manifest::check_indices() const {
  auto check = [](uint64_t index, uint64_t count, const std::string& where, const char* of) {
    if (index >= count)
      throw ManifestError(where, "index " + std::to_string(index) + " is out of range (" + std::to_string(count) + " " + of + ")");
  };
  for (size_t b = 0; b < binaries.size(); ++b) {
    const std::string at = "/binaries/" + std::to_string(b);
    for (const auto& [target, id] : binaries[b].blobs)
      check(id, archive.blobs, at + "/blobs/" + std::string(target_name(target)), "blobs");
    check(binaries[b].reflection, reflections.size(), at + "/reflection", "reflections");
  }
  for (size_t p = 0; p < passes.size(); ++p)
    for (size_t v = 0; v < passes[p].variants.size(); ++v)
      for (const auto& [stage, id] : passes[p].variants[v].binaries)
        check(id, binaries.size(),
              "/passes/" + std::to_string(p) + "/variants/" + std::to_string(v) + "/binaries/" + std::string(stage_name(stage)),
              "binaries");
}

}  // namespace kiln
