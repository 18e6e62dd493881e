#include "kiln/manifest_json.hpp"

#include <algorithm>
#include <limits>
#include <tuple>
#include <type_traits>

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

constexpr std::array<std::string_view, 6> kResourceKindNames{"uniform_buffer", "storage_buffer", "texture",
                                                             "sampler",        "combined_image_sampler", "storage_image"};
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

// ---- Writing ---------------------------------------------------------------------------------------------------

template <class Key, class T>
json keyed_object(const std::map<Key, T>& map) {
  json out = json::object();
  for (const auto& [key, value] : map) {
    if constexpr (std::is_same_v<Key, Stage>) out[std::string(stage_name(key))] = value;
    else if constexpr (std::is_same_v<Key, Target>) out[std::string(target_name(key))] = value;
    else out[key] = value;
  }
  return out;
}

}  // namespace

std::string_view resource_kind_name(ResourceKind kind) { return kResourceKindNames[static_cast<size_t>(kind)]; }

std::optional<ResourceKind> parse_resource_kind(std::string_view name) {
  return parse_name<ResourceKind>(kResourceKindNames, name);
}

// ---- Reflection ------------------------------------------------------------------------------------------------

void to_json(json& j, const BlockMember& v) {
  j = {{"name", v.name}, {"offset", v.offset}, {"size", v.size}, {"type", v.type}};
  if (v.array_stride) j["array_stride"] = *v.array_stride;
}
void from_json(const json& j, BlockMember& v) {
  read(j, "name", v.name);
  read(j, "offset", v.offset);
  read(j, "size", v.size);
  read(j, "type", v.type);
  read_if_present(j, "array_stride", v.array_stride);
}

void to_json(json& j, const Resource& v) {
  j = {{"name", v.name}, {"kind", resource_kind_name(v.kind)}, {"set", v.set}, {"binding", v.binding}, {"count", v.count}};
  if (is_block(v.kind)) {
    j["size"] = v.size;
    j["members"] = v.members;
  } else if (is_image(v.kind)) {
    j["dimension"] = v.dimension;
    if (v.depth) j["depth"] = true;
  }
}
void from_json(const json& j, Resource& v) {
  read(j, "name", v.name);
  read(j, "kind", v.kind);
  read(j, "set", v.set);
  read(j, "binding", v.binding);
  read(j, "count", v.count);
  if (is_block(v.kind)) {
    read(j, "size", v.size);
    read(j, "members", v.members);
  } else if (is_image(v.kind)) {
    read(j, "dimension", v.dimension);
    read_if_present(j, "depth", v.depth);
  }
}

void to_json(json& j, const PushConstantBlock& v) { j = {{"name", v.name}, {"size", v.size}, {"members", v.members}}; }
void from_json(const json& j, PushConstantBlock& v) {
  read(j, "name", v.name);
  read(j, "size", v.size);
  read(j, "members", v.members);
}

void to_json(json& j, const StageVariable& v) {
  j = {{"name", v.name}, {"location", v.location}, {"type", v.type}};
  if (!v.semantic.empty()) j["semantic"] = v.semantic;
}
void from_json(const json& j, StageVariable& v) {
  read(j, "name", v.name);
  read(j, "location", v.location);
  read(j, "type", v.type);
  read_if_present(j, "semantic", v.semantic);
}

void to_json(json& j, const GlCombinedSampler& v) {
  j = {{"name", v.name}, {"texture", v.texture}, {"sampler", v.sampler}, {"binding", v.binding}};
}
void from_json(const json& j, GlCombinedSampler& v) {
  read(j, "name", v.name);
  read(j, "texture", v.texture);
  read(j, "sampler", v.sampler);
  read(j, "binding", v.binding);
}

void to_json(json& j, const GlBlock& v) {
  j = {{"name", v.name}, {"kind", resource_kind_name(v.kind)}, {"binding", v.binding}};
}
void from_json(const json& j, GlBlock& v) {
  read(j, "name", v.name);
  read(j, "kind", v.kind);
  if (!is_block(v.kind)) throw ManifestError("/kind", "is not a block kind");
  read(j, "binding", v.binding);
}

void to_json(json& j, const GlBindings& v) {
  j = {{"combined_image_samplers", v.combined_image_samplers}, {"blocks", v.blocks}};
}
void from_json(const json& j, GlBindings& v) {
  read(j, "combined_image_samplers", v.combined_image_samplers);
  read(j, "blocks", v.blocks);
}

void to_json(json& j, const MslResource& v) {
  j = {{"name", v.name}, {"kind", kMslKindNames[static_cast<size_t>(v.kind)]}, {"index", v.index}};
}
void from_json(const json& j, MslResource& v) {
  read(j, "name", v.name);
  read(j, "kind", v.kind);
  read(j, "index", v.index);
}

void to_json(json& j, const MslBindings& v) { j = {{"resources", v.resources}}; }
void from_json(const json& j, MslBindings& v) { read(j, "resources", v.resources); }

void to_json(json& j, const Reflection& v) {
  j = {{"resources", v.resources}, {"push_constants", v.push_constants}, {"inputs", v.inputs}, {"outputs", v.outputs}};
  if (v.local_size) j["local_size"] = *v.local_size;
  if (v.glsl) j[std::string(target_name(Target::Glsl))] = *v.glsl;
  if (v.gles) j[std::string(target_name(Target::Gles))] = *v.gles;
  if (v.msl) j[std::string(target_name(Target::Msl))] = *v.msl;
}
void from_json(const json& j, Reflection& v) {
  read(j, "resources", v.resources);
  read(j, "push_constants", v.push_constants);
  read(j, "inputs", v.inputs);
  read(j, "outputs", v.outputs);
  read_if_present(j, "local_size", v.local_size);
  if (v.local_size && ((*v.local_size)[0] == 0 || (*v.local_size)[1] == 0 || (*v.local_size)[2] == 0))
    throw ManifestError("/local_size", "has a thread-group size of 0");
  read_if_present(j, "glsl", v.glsl);
  read_if_present(j, "gles", v.gles);
  read_if_present(j, "msl", v.msl);
}

bool Reflection::holds(const Resource& resource) const {
  return std::find(resources.begin(), resources.end(), resource) != resources.end();
}

void to_json(json& j, const PassLayout& v) { j = {{"resources", v.resources}, {"push_constants", v.push_constants}}; }
void from_json(const json& j, PassLayout& v) {
  read(j, "resources", v.resources);
  read(j, "push_constants", v.push_constants);
}

// ---- Manifest --------------------------------------------------------------------------------------------------

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

void to_json(json& j, const ManifestVariant& v) { j = {{"keywords", v.keywords}, {"binaries", keyed_object(v.binaries)}}; }
void from_json(const json& j, ManifestVariant& v) {
  read(j, "keywords", v.keywords);
  read(j, "binaries", v.binaries);
}

void to_json(json& j, const ManifestPass& v) {
  j = {{"name", v.name},
       {"stages", keyed_object(v.entry_points)},
       {"keyword_groups", v.keyword_groups},
       {"layout", v.layout},
       {"variants", v.variants}};
  if (!v.bindings.empty()) j["bindings"] = v.bindings;
  if (!v.defines.empty()) j["defines"] = keyed_object(v.defines);
  if (!v.targets.empty()) {
    json targets = json::array();
    for (Target t : v.targets) targets.push_back(target_name(t));
    j["targets"] = targets;
  }
}
void from_json(const json& j, ManifestPass& v) {
  read(j, "name", v.name);
  read(j, "stages", v.entry_points);
  read(j, "keyword_groups", v.keyword_groups);
  read(j, "layout", v.layout);
  read(j, "variants", v.variants);
  read_if_present(j, "bindings", v.bindings);
  read_if_present(j, "defines", v.defines);
  read_if_present(j, "targets", v.targets);
}

void to_json(json& j, const ManifestBinary& v) {
  j = {{"stage", stage_name(v.stage)}, {"entry", v.entry}, {"blobs", keyed_object(v.blobs)}, {"reflection", v.reflection}};
}
void from_json(const json& j, ManifestBinary& v) {
  read(j, "stage", v.stage);
  read(j, "entry", v.entry);
  read(j, "blobs", v.blobs);
  read(j, "reflection", v.reflection);
}

void to_json(json& j, const ManifestConstraint& v) {
  j = {{"keyword", v.keyword}};
  if (!v.requires_all.empty()) j["requires"] = v.requires_all;
  if (!v.requires_any.empty()) j["requires_any"] = v.requires_any;
  if (!v.excludes.empty()) j["excludes"] = v.excludes;
  if (!v.reason.empty()) j["reason"] = v.reason;
}
void from_json(const json& j, ManifestConstraint& v) {
  read(j, "keyword", v.keyword);
  read_if_present(j, "requires", v.requires_all);
  read_if_present(j, "requires_any", v.requires_any);
  read_if_present(j, "excludes", v.excludes);
  read_if_present(j, "reason", v.reason);
}

void to_json(json& j, const ManifestMaterial& v) { j = {{"name", v.name}, {"keywords", v.keywords}}; }
void from_json(const json& j, ManifestMaterial& v) {
  read(j, "name", v.name);
  read(j, "keywords", v.keywords);
}

void to_json(json& j, const ManifestTools& v) {
  j = {{"frontend", v.frontend}, {"spirv_tools", v.spirv_tools}, {"spirv_cross", v.spirv_cross}};
}
void from_json(const json& j, ManifestTools& v) {
  read(j, "frontend", v.frontend);
  read(j, "spirv_tools", v.spirv_tools);
  read(j, "spirv_cross", v.spirv_cross);
}

void to_json(json& j, const ManifestOptions& v) {
  json targets = json::array();
  for (Target t : v.targets) targets.push_back(target_name(t));
  j = {{"optimize", v.optimize},         {"optimizer_recipe", v.optimizer_recipe}, {"targets", targets},
       {"spirv_env", v.spirv_env},       {"glsl_version", v.glsl_version},
       {"gles_version", v.gles_version}, {"msl_version", v.msl_version},
       {"gl_clip_space_fixup", v.gl_clip_space_fixup}};
}
void from_json(const json& j, ManifestOptions& v) {
  read(j, "optimize", v.optimize);
  read(j, "optimizer_recipe", v.optimizer_recipe);
  read(j, "targets", v.targets);
  read(j, "spirv_env", v.spirv_env);
  read(j, "glsl_version", v.glsl_version);
  read(j, "gles_version", v.gles_version);
  read(j, "msl_version", v.msl_version);
  read(j, "gl_clip_space_fixup", v.gl_clip_space_fixup);
}

void to_json(json& j, const ManifestFunnel& v) {
  j = {{"declared", v.declared},
       {"valid", v.valid},
       {"kept", v.kept},
       {"stage_instances", v.stage_instances},
       {"unique_preprocessed", v.unique_preprocessed},
       {"unique_compiles", v.unique_compiles},
       {"unique_modules", v.unique_modules},
       {"unique_binaries", v.unique_binaries}};
}
void from_json(const json& j, ManifestFunnel& v) {
  read(j, "declared", v.declared);
  read(j, "valid", v.valid);
  read(j, "kept", v.kept);
  read(j, "stage_instances", v.stage_instances);
  read(j, "unique_preprocessed", v.unique_preprocessed);
  read(j, "unique_compiles", v.unique_compiles);
  read(j, "unique_modules", v.unique_modules);
  read(j, "unique_binaries", v.unique_binaries);
}

void to_json(json& j, const ManifestArchive& v) {
  j = {{"file", v.file}, {"size", v.size}, {"xxh3_64", v.xxh3_64}, {"blobs", v.blobs}};
}
void from_json(const json& j, ManifestArchive& v) {
  read(j, "file", v.file);
  read(j, "size", v.size);
  read(j, "xxh3_64", v.xxh3_64);
  read(j, "blobs", v.blobs);
}

void to_json(json& j, const Manifest& v) {
  j = {{"format", kManifestFormat},
       {"format_version", v.format_version},
       {"name", v.name},
       {"kiln_version", v.kiln_version},
       {"tools", v.tools},
       {"options", v.options},
       {"inputs_hash", v.inputs_hash},
       {"funnel", v.funnel},
       {"constraints", v.constraints},
       {"materials", v.materials},
       {"scene_features", json::parse(v.scene_features_json)},
       {"passes", v.passes},
       {"binaries", v.binaries},
       {"reflections", v.reflections},
       {"archive", v.archive}};
}
void from_json(const json& j, Manifest& v) {
  // The fields a reader needs first (the name, the archive, the records selection reads), then the rest.
  read(j, "format_version", v.format_version);
  read(j, "name", v.name);
  read(j, "archive", v.archive);
  read(j, "binaries", v.binaries);
  read(j, "reflections", v.reflections);
  read(j, "passes", v.passes);
  read(j, "kiln_version", v.kiln_version);
  read(j, "tools", v.tools);
  read(j, "options", v.options);
  read(j, "inputs_hash", v.inputs_hash);
  read(j, "funnel", v.funnel);
  read(j, "constraints", v.constraints);
  read(j, "materials", v.materials);
  const json& scene_features = member(j, "scene_features");
  if (!scene_features.is_object()) throw ManifestError("/scene_features", "is not an object");
  v.scene_features_json = scene_features.dump();
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
