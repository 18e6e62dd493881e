// SPDX-License-Identifier: Apache-2.0
#include "render/scene_data.hpp"

#include "kiln/coverage_map.hpp"

#include <cmath>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

namespace kiln::render {


void render_error(const std::string& message) { fail(DiagId::PackUnusable, {}, message); }
void render_error(DiagId id, const std::string& message) { fail(id, {}, message); }


DfgTable load_dfg(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(DiagId::GoldenData, path, "cannot open the DFG table");
  std::stringstream s;
  s << in.rdbuf();
  const std::string bytes = s.str();
  uint32_t header[4];
  if (bytes.size() < 20 || bytes.compare(0, 4, "KDFG") != 0) fail(DiagId::GoldenData, path, "not a KDFG table");
  std::memcpy(header, bytes.data() + 4, 16);
  // Version 3: columns spaced in cbrt(NoV) (verify/reference/reference.hpp); the renderers only upload the texels.
  if (header[0] != 3) fail(DiagId::GoldenData, path, "KDFG version " + std::to_string(header[0]) + " (expected 3)");
  DfgTable t{header[1], header[2], {}};
  t.rg.resize(size_t(t.width) * t.height * 2);
  if (bytes.size() != 20 + t.rg.size() * 4) fail(DiagId::GoldenData, path, "truncated KDFG table");
  std::memcpy(t.rg.data(), bytes.data() + 20, t.rg.size() * 4);
  return t;
}

const ManifestPass& find_pass(const PackReader& pack, const std::string& name) {
  if (const ManifestPass* pass = pack.manifest().pass(name)) return *pass;
  render_error("pack '" + pack.name() + "' has no " + name + " pass");
}

const Resource* find_resource(const ManifestPass& pass, const std::string& name) {
  for (const Resource& r : pass.layout.resources)
    if (r.name == name) return &r;
  return nullptr;
}

BlockWriter::BlockWriter(const Resource& block) : block_(block), bytes_(block.size, 0) {}

void BlockWriter::floats(const std::string& member, std::initializer_list<double> values, size_t element) {
  std::vector<float> f(values.begin(), values.end());
  write(member, f.data(), f.size() * 4, element);
}

void BlockWriter::uints(const std::string& member, std::initializer_list<uint32_t> values) {
  std::vector<uint32_t> u(values);
  write(member, u.data(), u.size() * 4, 0);
}

void BlockWriter::matrix(const std::string& member, const Mat4& m, size_t element) {
  float f[16];
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) f[c * 4 + r] = static_cast<float>(m[r][c]);
  write(member, f, sizeof f, element);
}

void BlockWriter::write(const std::string& member, const void* data, size_t size, size_t element) {
  for (const BlockMember& m : block_.members) {
    if (m.name != member) continue;
    size_t offset = m.offset + element * m.array_stride.value_or(0);
    if (offset + size > bytes_.size()) render_error("member " + member + " overruns block " + block_.name);
    std::memcpy(bytes_.data() + offset, data, size);
    return;
  }
}

namespace {

const std::set<std::string>& provided_resources() {
  static const std::set<std::string> names = {
      "PerFrame", "PerMaterial", "PerObject", "_MainLightShadowMap", "sampler_ShadowCompare",
      "_AdditionalLightsShadowMap", "_EnvironmentMap", "sampler_LinearClamp", "_DFG", "_AdditionalLights",
      "_TileLightIndices", "_AdditionalShadowMatrices", "ShadowCaster", std::string(kCoverageBufferName),
      std::string(kKeywordBlockName)};
  return names;
}

void matrix_std430(float* out, const Mat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) out[c * 4 + r] = static_cast<float>(m[r][c]);
}

template <typename T>
Bytes as_bytes(const std::vector<T>& values) {
  Bytes b(values.size() * sizeof(T));
  if (!b.empty()) std::memcpy(b.data(), values.data(), b.size());
  return b;
}

}  // namespace

bool is_provided_resource(const std::string& name) { return provided_resources().count(name) != 0; }

std::vector<MeshAttribute> mesh_attributes(const StageView& vertex) {
  std::vector<MeshAttribute> attributes;
  if (!vertex.reflection) return attributes;
  // By the inputs' HLSL semantics, as a game binds its vertex streams (the names are the shader author's).
  for (const StageVariable& input : vertex.reflection->inputs) {
    const uint32_t location = input.location;
    if (input.semantic == "POSITION") attributes.push_back({location, 3, 0});
    else if (input.semantic == "NORMAL") attributes.push_back({location, 3, 12});
    else if (input.semantic == "TANGENT") attributes.push_back({location, 4, 24});
    else if (input.semantic == "TEXCOORD0") attributes.push_back({location, 2, 40});
    else
      render_error("vertex input '" + input.name + "' (semantic '" + input.semantic +
                   "') has no mesh attribute (POSITION, NORMAL, TANGENT, TEXCOORD0)");
  }
  return attributes;
}

SceneData::SceneData(const PackReader& pack, const Scene& scene)
    : pack_(pack), scene_(scene), forward_(find_pass(pack, "Forward")), shadow_(find_pass(pack, "ShadowCaster")) {
  for (const Resource& r : forward_.layout.resources)
    if (!is_provided_resource(r.name))
      render_error("the Forward pass binds '" + r.name + "', which the renderer does not provide");
  environment_ = load_environment(scene_.environment);
  dfg_ = load_dfg(scene_.dfg);

  const Resource* material_block = find_resource(forward_, "PerMaterial");
  const Resource* object_block = find_resource(forward_, "PerObject");
  if (!material_block || !object_block) render_error("the Forward pass has no PerMaterial/PerObject constant buffer");
  for (const Object& o : scene_.objects) {
    BlockWriter mw(*material_block);
    mw.floats("_BaseColor", {o.material.base_color[0], o.material.base_color[1], o.material.base_color[2], 1.0});
    mw.floats("_Metallic", {o.material.metallic});
    mw.floats("_PerceptualRoughness", {o.material.perceptual_roughness});
    mw.floats("_Reflectance", {o.material.reflectance});
    mw.floats("_Anisotropy", {o.material.anisotropy});
    per_material_.push_back(mw.take());
    BlockWriter ow(*object_block);
    Mat4 world = object_to_world(o);
    ow.matrix("_ObjectToWorld", world);
    ow.matrix("_WorldToObject", mat_inverse(world));
    per_object_.push_back(ow.take());
  }

  // Lights (64 bytes each, std430), the Forward+ tile lists and the punctual shadow matrices: none of them
  // depends on the main-light cascade layout.
  const FrameSetup base = setup_frame(scene_, 1);
  std::vector<float> lights(std::max<size_t>(scene_.lights.size(), 1) * 16, 0.0f);
  for (size_t i = 0; i < scene_.lights.size(); ++i) {
    const AdditionalLightDesc& l = scene_.lights[i];
    double cos_inner = std::cos(l.inner_degrees * 3.14159265358979323846 / 180);
    double cos_outer = std::cos(l.outer_degrees * 3.14159265358979323846 / 180);
    double spot_scale = 1.0 / std::max(cos_inner - cos_outer, 1e-4);
    float record[16] = {float(l.position[0]), float(l.position[1]), float(l.position[2]), float(1.0 / (l.range * l.range)),
                        float(l.color[0] * l.intensity), float(l.color[1] * l.intensity), float(l.color[2] * l.intensity),
                        float(base.light_first_shadow_view[i]),
                        float(l.direction[0]), float(l.direction[1]), float(l.direction[2]), l.spot ? 1.0f : 0.0f,
                        float(spot_scale), float(-cos_outer * spot_scale), 0.0f, 0.0f};
    std::memcpy(lights.data() + i * 16, record, sizeof record);
  }
  lights_ = as_bytes(lights);
  tiles_ = as_bytes(base.tile_lists);
  std::vector<float> matrices(std::max<size_t>(base.additional_views.size(), 1) * 16, 0.0f);
  for (size_t i = 0; i < base.additional_views.size(); ++i)
    matrix_std430(matrices.data() + i * 16, base.additional_views[i].world_to_shadow);
  shadow_matrices_ = as_bytes(matrices);

  try {
    pack_.select("ShadowCaster", {"_CASTING_PUNCTUAL_LIGHT_SHADOW"});
    punctual_caster_ = true;
  } catch (const PackError&) {
    punctual_caster_ = false;
  }
}

const SceneData::Frame& SceneData::frame(int cascades) {
  auto found = frames_.find(cascades);
  if (found != frames_.end()) return found->second;
  Frame f;
  f.setup = setup_frame(scene_, cascades);
  const Resource* block = find_resource(forward_, "PerFrame");
  if (!block) render_error("the Forward pass has no PerFrame constant buffer");
  BlockWriter w(*block);
  const Scene& sc = scene_;
  w.matrix("_ViewProjection", f.setup.view_projection);
  w.floats("_CameraPositionWS", {sc.camera_position[0], sc.camera_position[1], sc.camera_position[2], 1});
  w.floats("_MainLightDirectionWS", {sc.main_light_direction[0], sc.main_light_direction[1], sc.main_light_direction[2], 0});
  w.floats("_MainLightColor", {sc.main_light_color[0] * sc.main_light_illuminance, sc.main_light_color[1] * sc.main_light_illuminance,
                               sc.main_light_color[2] * sc.main_light_illuminance, 1});
  for (size_t c = 0; c < f.setup.main_views.size(); ++c) {
    w.matrix("_MainLightWorldToShadow", f.setup.main_views[c].world_to_shadow, c);
    const auto& sphere = f.setup.cascade_spheres[c];
    w.floats("_CascadeSplitSpheres", {sphere[0], sphere[1], sphere[2], sphere[3]}, c);
  }
  w.floats("_MainLightShadowParams", {sc.main_shadow.strength, sc.main_shadow.receiver_depth_bias,
                                      1.0 / f.setup.main_atlas_size, double(f.setup.main_views.size())});
  w.floats("_AdditionalShadowParams", {sc.additional_shadow.strength, sc.additional_shadow.receiver_depth_bias,
                                       1.0 / std::max(1u, f.setup.additional_atlas_width), 0});
  w.floats("_FogColor", {sc.fog_color[0], sc.fog_color[1], sc.fog_color[2], 1});
  w.floats("_FogParams", {sc.fog_density, sc.fog_start, sc.fog_end, 0});
  for (size_t i = 0; i < 9; ++i)
    w.floats("_AmbientSH", {environment_.sh[i][0], environment_.sh[i][1], environment_.sh[i][2], 0}, i);
  w.floats("_EnvironmentParams", {double(environment_.mips - 1), sc.exposure, sc.environment_intensity, 0});
  w.floats("_GlossyEnvironmentColor", {sc.glossy_environment_color[0], sc.glossy_environment_color[1], sc.glossy_environment_color[2], 0});
  const ReflectionProbe& probe = sc.probe;
  w.floats("_ProbePositionWS", {probe.position[0], probe.position[1], probe.position[2], probe.box_projection ? 1.0 : 0.0});
  w.floats("_ProbeBoxMin", {probe.box_min[0], probe.box_min[1], probe.box_min[2], 0});
  w.floats("_ProbeBoxMax", {probe.box_max[0], probe.box_max[1], probe.box_max[2], 0});
  w.uints("_LightCounts", {uint32_t(sc.lights.size()), sc.tile_size, f.setup.tiles_x, 0});
  w.floats("_CameraForwardWS", {f.setup.camera_forward[0], f.setup.camera_forward[1], f.setup.camera_forward[2], 0});
  f.per_frame = w.take();
  return frames_.emplace(cascades, std::move(f)).first->second;
}

const Bytes& SceneData::buffer(const std::string& name, size_t object, const Frame& frame) const {
  if (name == "PerFrame") return frame.per_frame;
  if (name == "PerMaterial") return per_material_.at(object);
  if (name == "PerObject") return per_object_.at(object);
  if (name == "_AdditionalLights") return lights_;
  if (name == "_TileLightIndices") return tiles_;
  if (name == "_AdditionalShadowMatrices") return shadow_matrices_;
  render_error("no buffer named '" + name + "' in the scene's resources");
}

Bytes SceneData::caster_constants(const ShadowView& view) const {
  const Resource* block = find_resource(shadow_, "ShadowCaster");
  if (!block) render_error("the ShadowCaster pass has no ShadowCaster constant buffer");
  BlockWriter w(*block);
  w.matrix("_ShadowViewProjection", view.view_projection);
  w.floats("_ShadowLightPositionWS", {view.light_position[0], view.light_position[1], view.light_position[2], 1});
  w.floats("_ShadowLightDirectionWS", {view.light_direction[0], view.light_direction[1], view.light_direction[2], 0});
  const ShadowDesc& d = view.punctual ? scene_.additional_shadow : scene_.main_shadow;
  w.floats("_ShadowBias", {d.caster_depth_bias, d.caster_normal_bias, 0, 0});
  return w.take();
}

}  // namespace kiln::render
