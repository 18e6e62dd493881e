// SPDX-License-Identifier: Apache-2.0
#include "scene/scene.hpp"
#include "scene/verify_error.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <sstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>

namespace kiln::render {
namespace {

constexpr double kPi = 3.14159265358979323846;

Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 add(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Vec3 scale(const Vec3& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec3 normalize(const Vec3& v) { return scale(v, 1.0 / std::sqrt(dot(v, v))); }

[[noreturn]] void fail(const std::filesystem::path& path, const std::string& message) {
  render::fail(DiagId::RenderScene, path, message);
}

Vec3 read_vec3(const nlohmann::json& j, const std::filesystem::path& path, const std::string& field) {
  if (!j.is_array() || j.size() != 3 || !j[0].is_number() || !j[1].is_number() || !j[2].is_number())
    fail(path, "'" + field + "' must be an array of 3 numbers");
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

double read_number(const nlohmann::json& object, const char* key, double fallback, const std::filesystem::path& path,
                   double low = -std::numeric_limits<double>::infinity(),
                   double high = std::numeric_limits<double>::infinity()) {
  if (!object.contains(key)) return fallback;
  if (!object[key].is_number()) fail(path, std::string("'") + key + "' must be a number");
  double v = object[key].get<double>();
  if (!(v >= low && v <= high))
    fail(path, std::string("'") + key + "' = " + std::to_string(v) + " is outside [" + std::to_string(low) + ", " +
                   std::to_string(high) + "]");
  return v;
}

Material read_material(const nlohmann::json& j, const std::filesystem::path& path) {
  Material m;
  if (j.contains("base_color")) m.base_color = read_vec3(j["base_color"], path, "base_color");
  m.metallic = read_number(j, "metallic", m.metallic, path, 0, 1);
  m.perceptual_roughness = read_number(j, "roughness", m.perceptual_roughness, path, 0, 1);
  m.reflectance = read_number(j, "reflectance", m.reflectance, path, 0, 1);
  m.anisotropy = read_number(j, "anisotropy", m.anisotropy, path, -1, 1);
  return m;
}

ShadowDesc read_shadow(const nlohmann::json& j, const std::filesystem::path& path) {
  ShadowDesc s;
  s.strength = read_number(j, "strength", s.strength, path, 0, 1);
  s.resolution = static_cast<uint32_t>(read_number(j, "resolution", s.resolution, path, 16, 4096));
  s.caster_depth_bias = read_number(j, "caster_depth_bias", s.caster_depth_bias, path, 0, 10);
  s.caster_normal_bias = read_number(j, "caster_normal_bias", s.caster_normal_bias, path, 0, 10);
  s.receiver_depth_bias = read_number(j, "receiver_depth_bias", s.receiver_depth_bias, path, 0, 1);
  s.max_distance = read_number(j, "max_distance", s.max_distance, path, 0.1, 1e4);
  return s;
}

}  // namespace

Mat4 mat_identity() {
  Mat4 m{};
  for (int i = 0; i < 4; ++i) m[i][i] = 1;
  return m;
}

Mat4 mat_multiply(const Mat4& a, const Mat4& b) {
  Mat4 r{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k) r[i][j] += a[i][k] * b[k][j];
  return r;
}

Mat4 mat_transpose(const Mat4& m) {
  Mat4 r{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) r[i][j] = m[j][i];
  return r;
}

Mat4 mat_inverse(const Mat4& m) {
  // Gauss-Jordan with partial pivoting; the matrices here are well conditioned (rigid + uniform scale).
  Mat4 a = m, r = mat_identity();
  for (int c = 0; c < 4; ++c) {
    int pivot = c;
    for (int i = c + 1; i < 4; ++i)
      if (std::abs(a[i][c]) > std::abs(a[pivot][c])) pivot = i;
    std::swap(a[c], a[pivot]);
    std::swap(r[c], r[pivot]);
    double inv = 1.0 / a[c][c];
    for (int j = 0; j < 4; ++j) {
      a[c][j] *= inv;
      r[c][j] *= inv;
    }
    for (int i = 0; i < 4; ++i) {
      if (i == c) continue;
      double f = a[i][c];
      for (int j = 0; j < 4; ++j) {
        a[i][j] -= f * a[c][j];
        r[i][j] -= f * r[c][j];
      }
    }
  }
  return r;
}

std::array<double, 4> mat_apply(const Mat4& m, const std::array<double, 4>& v) {
  std::array<double, 4> r{};
  for (int i = 0; i < 4; ++i) r[i] = m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2] + m[i][3] * v[3];
  return r;
}

Mat4 look_at(const Vec3& eye, const Vec3& target, const Vec3& up) {
  Vec3 f = normalize(sub(target, eye));
  Vec3 helper = std::abs(dot(f, normalize(up))) > 0.999 ? Vec3{1, 0, 0} : up;
  Vec3 s = normalize(cross(f, helper));
  Vec3 u = cross(s, f);
  Mat4 m = mat_identity();
  for (int j = 0; j < 3; ++j) {
    m[0][j] = s[j];
    m[1][j] = u[j];
    m[2][j] = -f[j];
  }
  m[0][3] = -dot(s, eye);
  m[1][3] = -dot(u, eye);
  m[2][3] = dot(f, eye);
  return m;
}

Mat4 perspective(double fov, double aspect, double n, double f) {
  double t = 1.0 / std::tan(fov / 2);
  Mat4 m{};
  m[0][0] = t / aspect;
  m[1][1] = -t;  // Vulkan: framebuffer y points down
  m[2][2] = f / (n - f);
  m[2][3] = n * f / (n - f);
  m[3][2] = -1;
  return m;
}

Mat4 orthographic(double hw, double hh, double n, double f) {
  Mat4 m{};
  m[0][0] = 1 / hw;
  m[1][1] = -1 / hh;
  m[2][2] = -1 / (f - n);
  m[2][3] = -n / (f - n);
  m[3][3] = 1;
  return m;
}

Mat4 object_to_world(const Object& object) {
  auto rotation = [](int axis, double degrees) {
    const double c = std::cos(degrees * kPi / 180), s = std::sin(degrees * kPi / 180);
    const int a = (axis + 1) % 3, b = (axis + 2) % 3;  // x: (y, z), y: (z, x), z: (x, y)
    Mat4 r = mat_identity();
    r[a][a] = c;
    r[a][b] = -s;
    r[b][a] = s;
    r[b][b] = c;
    return r;
  };
  Mat4 m = mat_identity();
  for (int i = 0; i < 3; ++i) m[i][i] = object.size * object.scale[i];
  for (int axis = 0; axis < 3; ++axis) m = mat_multiply(rotation(axis, object.rotation_degrees[axis]), m);
  for (int i = 0; i < 3; ++i) m[i][3] = object.position[i];
  return m;
}

int cascades_for(const std::vector<std::string>& keywords, const Scene& scene) {
  return std::find(keywords.begin(), keywords.end(), "_MAIN_LIGHT_SHADOWS_CASCADE") != keywords.end() ? scene.cascade_count : 1;
}

std::string variant_name(const std::vector<std::string>& keywords) {
  if (keywords.empty()) return "(none)";
  std::vector<std::string> sorted = keywords;
  std::sort(sorted.begin(), sorted.end());
  std::string name;
  for (const std::string& k : sorted) name += (name.empty() ? "" : " ") + k;
  return name;
}

bool Scene::judges(const std::string& variant) const {
  return judged_variants.empty() ||
         std::find(judged_variants.begin(), judged_variants.end(), variant) != judged_variants.end();
}

Scene load_scene(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open the scene file");
  const nlohmann::json j = parse_json_file(in, path, DiagId::RenderScene);
  if (!j.is_object() || !j.contains("render")) fail(path, "a render scene needs a \"render\" object");
  const nlohmann::json& r = j["render"];
  Scene scene;
  scene.path = path;
  scene.name = j.value("name", path.stem().string());
  if (j.contains("judged_variants")) {
    const auto& list = j["judged_variants"];
    if (!list.is_array() || list.empty()) fail(path, "'judged_variants' must be a non-empty list of keyword lists");
    for (const auto& v : list) {
      if (!v.is_string()) fail(path, "'judged_variants' must be a non-empty list of keyword lists");
      std::istringstream words(v.get<std::string>());
      scene.judged_variants.push_back(
          variant_name({std::istream_iterator<std::string>(words), std::istream_iterator<std::string>()}));
    }
  }
  if (r.contains("size")) {
    const auto& s = r["size"];
    if (!s.is_array() || s.size() != 2) fail(path, "'size' must be [width, height]");
    scene.width = s[0].get<uint32_t>();
    scene.height = s[1].get<uint32_t>();
  }
  if (r.contains("camera")) {
    const auto& c = r["camera"];
    if (c.contains("position")) scene.camera_position = read_vec3(c["position"], path, "camera.position");
    if (c.contains("target")) scene.camera_target = read_vec3(c["target"], path, "camera.target");
    scene.vertical_fov_degrees = read_number(c, "vertical_fov_degrees", scene.vertical_fov_degrees, path, 1, 170);
    scene.near_plane = read_number(c, "near", scene.near_plane, path, 1e-4, 1e4);
    scene.far_plane = read_number(c, "far", scene.far_plane, path, scene.near_plane, 1e6);
  }
  scene.exposure = read_number(r, "exposure", scene.exposure, path, 0, 1e9);
  if (r.contains("main_light")) {
    const auto& m = r["main_light"];
    if (m.contains("direction")) scene.main_light_direction = read_vec3(m["direction"], path, "main_light.direction");
    if (m.contains("color")) scene.main_light_color = read_vec3(m["color"], path, "main_light.color");
    scene.main_light_illuminance = read_number(m, "illuminance", scene.main_light_illuminance, path, 0, 1e9);
    if (m.contains("shadow")) scene.main_shadow = read_shadow(m["shadow"], path);
    scene.cascade_count = static_cast<int>(read_number(m, "cascades", scene.cascade_count, path, 1, 4));
  }
  scene.main_light_direction = normalize(scene.main_light_direction);
  if (r.contains("additional_shadow")) scene.additional_shadow = read_shadow(r["additional_shadow"], path);
  for (const auto& l : r.value("lights", nlohmann::json::array())) {
    AdditionalLightDesc light;
    std::string type = l.value("type", "point");
    if (type != "point" && type != "spot") fail(path, "light type '" + type + "' (expected point or spot)");
    light.spot = type == "spot";
    if (!l.contains("position")) fail(path, "a light needs a 'position'");
    light.position = read_vec3(l["position"], path, "light.position");
    if (l.contains("color")) light.color = read_vec3(l["color"], path, "light.color");
    light.intensity = read_number(l, "intensity", light.intensity, path, 0, 1e9);
    light.range = read_number(l, "range", light.range, path, 1e-3, 1e6);
    if (l.contains("direction")) light.direction = normalize(read_vec3(l["direction"], path, "light.direction"));
    light.inner_degrees = read_number(l, "inner_degrees", light.inner_degrees, path, 0, 89);
    light.outer_degrees = read_number(l, "outer_degrees", light.outer_degrees, path, light.inner_degrees, 89);
    light.shadow = l.value("shadow", false);
    scene.lights.push_back(light);
  }
  // A deterministic field of small point lights (the stress scene): count, area corners, height, range.
  if (r.contains("light_field")) {
    const auto& f = r["light_field"];
    int count = static_cast<int>(read_number(f, "count", 0, path, 0, 4096));
    Vec3 lo = read_vec3(f.value("min", nlohmann::json::array({-5, 0.3, -5})), path, "light_field.min");
    Vec3 hi = read_vec3(f.value("max", nlohmann::json::array({5, 0.3, 5})), path, "light_field.max");
    double range = read_number(f, "range", 1.0, path, 1e-3, 1e3);
    double intensity = read_number(f, "intensity", 1.0, path, 0, 1e9);
    int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(count))));
    for (int i = 0; i < count; ++i) {
      AdditionalLightDesc light;
      double u = (i % side + 0.5) / side, v = (i / side + 0.5) / side;
      light.position = {lo[0] + (hi[0] - lo[0]) * u, lo[1] + (hi[1] - lo[1]) * 0.5 * (1 + std::sin(i * 1.7)),
                        lo[2] + (hi[2] - lo[2]) * v};
      // Hues around the color wheel, so that a wrong light index shows as a wrong color.
      double h = std::fmod(i * 0.618033988749895, 1.0) * 2 * kPi;
      light.color = {0.55 + 0.45 * std::cos(h), 0.55 + 0.45 * std::cos(h - 2.094), 0.55 + 0.45 * std::cos(h + 2.094)};
      light.intensity = intensity;
      light.range = range;
      scene.lights.push_back(light);
    }
  }
  scene.tile_size = static_cast<uint32_t>(read_number(r, "tile_size", scene.tile_size, path, 4, 256));
  scene.tile_binning_range_scale =
      read_number(r, "tile_binning_range_scale", scene.tile_binning_range_scale, path, 1e-3, 1);
  if (r.contains("fog")) {
    const auto& f = r["fog"];
    if (f.contains("color")) scene.fog_color = read_vec3(f["color"], path, "fog.color");
    scene.fog_density = read_number(f, "density", scene.fog_density, path, 0, 100);
    scene.fog_start = read_number(f, "start", scene.fog_start, path, 0, 1e6);
    scene.fog_end = read_number(f, "end", scene.fog_end, path, 0, 1e6);
  }
  if (!r.contains("environment") || !r["environment"].contains("file"))
    fail(path, "'environment.file' is required (a KENV file written by kiln-reference environment)");
  const auto& env = r["environment"];
  scene.environment = path.parent_path() / env["file"].get<std::string>();
  if (!env.contains("dfg")) fail(path, "'environment.dfg' is required (the KDFG table, shaderlib/data/dfg64.kdfg)");
  scene.dfg = path.parent_path() / env["dfg"].get<std::string>();
  scene.environment_intensity = read_number(env, "intensity", scene.environment_intensity, path, 0, 1e9);
  if (env.contains("glossy_color")) scene.glossy_environment_color = read_vec3(env["glossy_color"], path, "glossy_color");
  if (r.contains("reflection_probe")) {
    const auto& probe = r["reflection_probe"];
    if (!probe.is_object() || !probe.contains("position") || !probe.contains("box_min") || !probe.contains("box_max"))
      fail(path, "'reflection_probe' needs 'position', 'box_min' and 'box_max'");
    scene.probe.box_projection = true;
    scene.probe.position = read_vec3(probe["position"], path, "reflection_probe.position");
    scene.probe.box_min = read_vec3(probe["box_min"], path, "reflection_probe.box_min");
    scene.probe.box_max = read_vec3(probe["box_max"], path, "reflection_probe.box_max");
    for (int a = 0; a < 3; ++a)
      if (!(scene.probe.box_min[a] < scene.probe.box_max[a]) || scene.probe.position[a] < scene.probe.box_min[a] ||
          scene.probe.position[a] > scene.probe.box_max[a])
        fail(path, "'reflection_probe': 'box_min' must be below 'box_max' on every axis, with 'position' inside the box");
  }
  for (const auto& o : r.value("objects", nlohmann::json::array())) {
    if (o.contains("sphere_grid")) {
      // Rows of spheres; columns sweep the roughness list.
      const auto& g = o["sphere_grid"];
      Vec3 origin = read_vec3(g.value("origin", nlohmann::json::array({0, 0.5, 0})), path, "sphere_grid.origin");
      double spacing = read_number(g, "spacing", 1.2, path, 0.01, 100);
      double radius = read_number(g, "radius", 0.5, path, 0.001, 100);
      auto roughness = g.value("roughness", std::vector<double>{0, 0.25, 0.5, 0.75, 1});
      int row = 0;
      for (const auto& row_material : g.value("rows", nlohmann::json::array())) {
        for (size_t c = 0; c < roughness.size(); ++c) {
          Object sphere;
          sphere.position = {origin[0] + spacing * static_cast<double>(c), origin[1], origin[2] - spacing * row};
          sphere.size = radius;
          sphere.material = read_material(row_material, path);
          sphere.material.perceptual_roughness = std::clamp(roughness[c], 0.0, 1.0);
          scene.objects.push_back(sphere);
        }
        ++row;
      }
      continue;
    }
    Object object;
    std::string shape = o.value("shape", "sphere");
    if (shape != "sphere" && shape != "plane") fail(path, "object shape '" + shape + "' (expected sphere or plane)");
    object.shape = shape == "plane" ? Object::Shape::Plane : Object::Shape::Sphere;
    if (o.contains("position")) object.position = read_vec3(o["position"], path, "object.position");
    object.size = read_number(o, "size", object.size, path, 1e-3, 1e4);
    if (o.contains("scale")) {
      object.scale = read_vec3(o["scale"], path, "object.scale");
      for (double v : object.scale)
        if (!(v >= 1e-3 && v <= 1e4)) fail(path, "'object.scale' components must be in [0.001, 10000]");
    }
    if (o.contains("rotation_degrees")) object.rotation_degrees = read_vec3(o["rotation_degrees"], path, "object.rotation_degrees");
    if (o.contains("material")) object.material = read_material(o["material"], path);
    scene.objects.push_back(object);
  }
  if (scene.objects.empty()) fail(path, "the scene has no objects");
  return scene;
}

Mesh make_sphere(uint32_t segments, uint32_t rings) {
  Mesh mesh;
  for (uint32_t r = 0; r <= rings; ++r) {
    double theta = kPi * r / rings;  // from +y down
    for (uint32_t s = 0; s <= segments; ++s) {
      double phi = 2 * kPi * s / segments;
      double x = std::sin(theta) * std::cos(phi), y = std::cos(theta), z = -std::sin(theta) * std::sin(phi);
      // Tangent along increasing phi (around +y), the direction anisotropic highlights stretch across.
      double tx = -std::sin(phi), tz = -std::cos(phi);
      float v[kVertexFloats] = {float(x), float(y), float(z), float(x), float(y), float(z),
                                float(tx), 0.0f, float(tz), 1.0f, float(double(s) / segments), float(double(r) / rings)};
      mesh.vertices.insert(mesh.vertices.end(), v, v + kVertexFloats);
    }
  }
  for (uint32_t r = 0; r < rings; ++r)
    for (uint32_t s = 0; s < segments; ++s) {
      uint32_t a = r * (segments + 1) + s, b = a + segments + 1;
      mesh.indices.insert(mesh.indices.end(), {a, b, a + 1, a + 1, b, b + 1});
    }
  return mesh;
}

Mesh make_plane(uint32_t cells) {
  Mesh mesh;
  for (uint32_t j = 0; j <= cells; ++j)
    for (uint32_t i = 0; i <= cells; ++i) {
      float x = -1.0f + 2.0f * i / cells, z = -1.0f + 2.0f * j / cells;
      float v[kVertexFloats] = {x, 0, z, 0, 1, 0, 1, 0, 0, 1, float(i) / cells, float(j) / cells};
      mesh.vertices.insert(mesh.vertices.end(), v, v + kVertexFloats);
    }
  for (uint32_t j = 0; j < cells; ++j)
    for (uint32_t i = 0; i < cells; ++i) {
      uint32_t a = j * (cells + 1) + i, b = a + cells + 1;
      mesh.indices.insert(mesh.indices.end(), {a, b, a + 1, a + 1, b, b + 1});
    }
  return mesh;
}

namespace {

// Maps clip space of a shadow camera to the atlas rectangle (x, y, size) of an atlas of width x height.
Mat4 clip_to_atlas(uint32_t x, uint32_t y, uint32_t size, uint32_t width, uint32_t height) {
  Mat4 m = mat_identity();
  m[0][0] = 0.5 * size / width;
  m[0][3] = (0.5 * size + x) / width;
  m[1][1] = 0.5 * size / height;
  m[1][3] = (0.5 * size + y) / height;
  return m;
}

struct Bounds {
  Vec3 center{0, 0, 0};
  double radius = 1;
};

Bounds scene_bounds(const Scene& scene) {
  Vec3 lo{1e30, 1e30, 1e30}, hi{-1e30, -1e30, -1e30};
  for (const Object& o : scene.objects) {
    // The transformed corners of the object's box in object space ([-1, 1]^3; a plane is flat in y).
    const Mat4 m = object_to_world(o);
    const double height = o.shape == Object::Shape::Plane ? 0 : 1;
    for (int corner = 0; corner < 8; ++corner) {
      auto p = mat_apply(m, {corner & 1 ? 1.0 : -1.0, corner & 2 ? height : -height, corner & 4 ? 1.0 : -1.0, 1});
      for (int i = 0; i < 3; ++i) {
        lo[i] = std::min(lo[i], p[i]);
        hi[i] = std::max(hi[i], p[i]);
      }
    }
  }
  Bounds b;
  b.center = scale(add(lo, hi), 0.5);
  b.radius = std::sqrt(dot(sub(hi, lo), sub(hi, lo))) * 0.5;
  return b;
}

ShadowView directional_view(const Vec3& direction, const Bounds& bounds, uint32_t x, uint32_t y, uint32_t size,
                            uint32_t atlas, double scene_radius) {
  ShadowView v;
  double depth = bounds.radius + scene_radius;  // casters outside the cascade sphere still cast into it
  Vec3 eye = add(bounds.center, scale(direction, depth));
  Mat4 view = look_at(eye, bounds.center, {0, 1, 0});
  v.view_projection = mat_multiply(orthographic(bounds.radius, bounds.radius, 0.0, 2 * depth), view);
  v.world_to_shadow = mat_multiply(clip_to_atlas(x, y, size, atlas, atlas), v.view_projection);
  v.x = x;
  v.y = y;
  v.size = size;
  v.light_direction = direction;
  return v;
}

}  // namespace

FrameSetup setup_frame(const Scene& scene, int cascades) {
  FrameSetup f;
  const double aspect = double(scene.width) / scene.height;
  Mat4 view = look_at(scene.camera_position, scene.camera_target, {0, 1, 0});
  Mat4 projection = perspective(scene.vertical_fov_degrees * kPi / 180, aspect, scene.near_plane, scene.far_plane);
  f.view_projection = mat_multiply(projection, view);
  f.camera_forward = normalize(sub(scene.camera_target, scene.camera_position));
  Bounds all = scene_bounds(scene);

  // Main light: one map over the whole scene, or cascades over slices of the view (2x2 atlas).
  f.cascades = cascades;
  const uint32_t res = scene.main_shadow.resolution;
  if (cascades <= 1) {
    f.main_atlas_size = res;
    f.main_views.push_back(directional_view(scene.main_light_direction, all, 0, 0, res, res, all.radius));
    f.cascade_spheres[0] = {all.center[0], all.center[1], all.center[2], all.radius * all.radius};
  } else {
    f.main_atlas_size = 2 * res;
    const double splits[] = {0.1, 0.25, 0.5, 1.0};
    double tan_y = std::tan(scene.vertical_fov_degrees * kPi / 360), tan_x = tan_y * aspect;
    Vec3 right = normalize(cross(f.camera_forward, {0, 1, 0}));
    Vec3 up = cross(right, f.camera_forward);
    double previous = scene.near_plane;
    for (int c = 0; c < cascades; ++c) {
      double far_distance = scene.main_shadow.max_distance * splits[c + 4 - cascades];
      // Bounding sphere of the frustum slice's eight corners, centred on the view axis.
      double mid = 0.5 * (previous + far_distance);
      Vec3 center = add(scene.camera_position, scale(f.camera_forward, mid));
      double radius = 0;
      for (double d : {previous, far_distance})
        for (double sx : {-1.0, 1.0})
          for (double sy : {-1.0, 1.0}) {
            Vec3 corner = add(scene.camera_position, add(scale(f.camera_forward, d),
                                                         add(scale(right, sx * tan_x * d), scale(up, sy * tan_y * d))));
            radius = std::max(radius, std::sqrt(dot(sub(corner, center), sub(corner, center))));
          }
      Bounds b{center, radius};
      f.main_views.push_back(directional_view(scene.main_light_direction, b, (c % 2) * res, (c / 2) * res, res,
                                              2 * res, all.radius));
      f.cascade_spheres[c] = {center[0], center[1], center[2], radius * radius};
      previous = far_distance;
    }
  }

  // Additional lights: a square atlas of square tiles (spot 1 tile, point 6).
  uint32_t views_needed = 0;
  for (const auto& l : scene.lights)
    if (l.shadow) views_needed += l.spot ? 1 : 6;
  if (views_needed > 0) {
    uint32_t grid = static_cast<uint32_t>(std::ceil(std::sqrt(double(views_needed))));
    const uint32_t tile = scene.additional_shadow.resolution;
    f.additional_atlas_width = f.additional_atlas_height = grid * tile;
    uint32_t next = 0;
    auto add_view = [&](const AdditionalLightDesc& l, const Mat4& view_projection) {
      ShadowView v;
      v.x = (next % grid) * tile;
      v.y = (next / grid) * tile;
      v.size = tile;
      v.view_projection = view_projection;
      v.world_to_shadow = mat_multiply(clip_to_atlas(v.x, v.y, tile, grid * tile, grid * tile), view_projection);
      v.punctual = true;
      v.light_position = l.position;
      f.additional_views.push_back(v);
      ++next;
    };
    for (const auto& l : scene.lights) {
      if (!l.shadow) {
        f.light_first_shadow_view.push_back(-1);
        continue;
      }
      f.light_first_shadow_view.push_back(static_cast<int>(next));
      const double n = 0.05;
      if (l.spot) {
        Mat4 p = perspective(2 * (l.outer_degrees + 5) * kPi / 180, 1, n, l.range);
        add_view(l, mat_multiply(p, look_at(l.position, add(l.position, l.direction), {0, 1, 0})));
      } else {
        const Vec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
        Mat4 p = perspective(kPi / 2, 1, n, l.range);
        for (const Vec3& axis : axes) add_view(l, mat_multiply(p, look_at(l.position, add(l.position, axis), {0, 1, 0})));
      }
    }
  } else {
    f.light_first_shadow_view.assign(scene.lights.size(), -1);
  }

  // Forward+ tiles: every light whose bounding box may touch a tile is listed for it (conservative, so a
  // listed light that does not reach a pixel contributes exactly 0 there, as in the plain loop).
  f.tiles_x = (scene.width + scene.tile_size - 1) / scene.tile_size;
  f.tiles_y = (scene.height + scene.tile_size - 1) / scene.tile_size;
  f.tile_lists.assign(size_t(f.tiles_x) * f.tiles_y * kTileStride, 0u);
  for (uint32_t index = 0; index < scene.lights.size(); ++index) {
    const auto& l = scene.lights[index];
    double x0 = 1e30, y0 = 1e30, x1 = -1e30, y1 = -1e30;
    bool everywhere = false;
    const double r = l.range * scene.tile_binning_range_scale;
    for (int corner = 0; corner < 8; ++corner) {
      Vec3 p = {l.position[0] + ((corner & 1) ? r : -r), l.position[1] + ((corner & 2) ? r : -r),
                l.position[2] + ((corner & 4) ? r : -r)};
      auto clip = mat_apply(f.view_projection, {p[0], p[1], p[2], 1});
      if (clip[3] <= scene.near_plane * 0.5) {
        everywhere = true;
        break;
      }
      double px = (clip[0] / clip[3] + 1) * 0.5 * scene.width, py = (clip[1] / clip[3] + 1) * 0.5 * scene.height;
      x0 = std::min(x0, px), y0 = std::min(y0, py), x1 = std::max(x1, px), y1 = std::max(y1, py);
    }
    int tx0 = 0, ty0 = 0, tx1 = int(f.tiles_x) - 1, ty1 = int(f.tiles_y) - 1;
    if (!everywhere) {
      tx0 = std::max(tx0, int(std::floor((x0 - 1) / scene.tile_size)));
      ty0 = std::max(ty0, int(std::floor((y0 - 1) / scene.tile_size)));
      tx1 = std::min(tx1, int(std::floor((x1 + 1) / scene.tile_size)));
      ty1 = std::min(ty1, int(std::floor((y1 + 1) / scene.tile_size)));
    }
    for (int ty = ty0; ty <= ty1; ++ty)
      for (int tx = tx0; tx <= tx1; ++tx) {
        uint32_t* list = &f.tile_lists[(size_t(ty) * f.tiles_x + tx) * kTileStride];
        if (list[0] >= kMaxLightsPerTile)
          fail(scene.path, "more than " + std::to_string(kMaxLightsPerTile) + " lights reach Forward+ tile (" +
                               std::to_string(tx) + ", " + std::to_string(ty) +
                               "); use smaller light ranges or a smaller tile_size");
        list[1 + list[0]++] = index;
      }
  }
  return f;
}

}  // namespace kiln::render
