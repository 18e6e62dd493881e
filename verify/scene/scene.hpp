// SPDX-License-Identifier: Apache-2.0
// A test scene for `kiln render` / `kiln test` (JSON, variants/scenes/render/*.json) and what the renderer
// derives from it: camera and shadow matrices, light records, the Forward+ tile lists, meshes. The CPU
// reference reads the same Scene (it is input data, like the geometry); it never reads the renderer's
// shading code.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace kiln::render {

using Vec3 = std::array<double, 3>;
// Row-major 4x4: m[row][column]; transforms column vectors (p' = M p), as HLSL's mul(M, p).
using Mat4 = std::array<std::array<double, 4>, 4>;

Mat4 mat_identity();
Mat4 mat_multiply(const Mat4& a, const Mat4& b);
Mat4 mat_inverse(const Mat4& m);
Mat4 mat_transpose(const Mat4& m);
std::array<double, 4> mat_apply(const Mat4& m, const std::array<double, 4>& v);
Mat4 look_at(const Vec3& eye, const Vec3& target, const Vec3& up);  // view: camera looks down -z
// Vulkan clip space: depth 0 (near) .. 1 (far), y down in the framebuffer.
Mat4 perspective(double vertical_fov_radians, double aspect, double near_plane, double far_plane);
Mat4 orthographic(double half_width, double half_height, double near_plane, double far_plane);

struct Material {
  Vec3 base_color{0.8, 0.8, 0.8};
  double metallic = 0;
  double perceptual_roughness = 0.5;
  double reflectance = 0.5;
  double anisotropy = 0;
};

struct Object {
  enum class Shape { Sphere, Plane };
  Shape shape = Shape::Sphere;
  Vec3 position{0, 0, 0};
  double size = 1;  // sphere radius, plane half-extent
  // Object space to world: scale (size times this, per axis), then rotate about x, then y, then z (degrees), then
  // translate. A non-uniform scale or a rotation makes object-space and world-space normals differ.
  Vec3 scale{1, 1, 1};
  Vec3 rotation_degrees{0, 0, 0};
  Material material;
};

struct AdditionalLightDesc {
  bool spot = false;
  Vec3 position{0, 0, 0};
  Vec3 color{1, 1, 1};        // linear
  double intensity = 1;       // candela
  double range = 5;
  Vec3 direction{0, -1, 0};   // spot axis, from the light
  double inner_degrees = 20;  // spot cone half-angles
  double outer_degrees = 30;
  bool shadow = false;
};

struct ShadowDesc {
  double strength = 1;
  uint32_t resolution = 512;
  double caster_depth_bias = 0.02;   // world units along L (ShadowCaster pass)
  double caster_normal_bias = 0.02;  // world units against N
  double receiver_depth_bias = 0.0005;  // shadow-map depth units (Forward pass)
  double max_distance = 20;          // main light: shadows end here (cascade splits divide it)
};

// A reflection probe with box projection (Unity's): the environment cubemap is taken as captured at `position`
// inside the box, so a reflection ray is followed to where it leaves the box and the cubemap is sampled towards that
// point from the probe, which makes reflections of a room shift with the viewer as they do in it.
struct ReflectionProbe {
  bool box_projection = false;  // off: the cubemap is at infinity (sampled along the ray)
  Vec3 position{0, 0, 0};
  Vec3 box_min{-1, -1, -1};
  Vec3 box_max{1, 1, 1};
};

struct Scene {
  std::string name;
  std::filesystem::path path;
  uint32_t width = 128;
  uint32_t height = 128;
  Vec3 camera_position{0, 3, 8};
  Vec3 camera_target{0, 0.5, 0};
  double vertical_fov_degrees = 40;
  double near_plane = 0.1;
  double far_plane = 60;
  double exposure = 1;
  Vec3 main_light_direction{0.3, 1, 0.4};  // towards the light
  Vec3 main_light_color{1, 1, 1};
  double main_light_illuminance = 3;
  ShadowDesc main_shadow;
  int cascade_count = 4;                   // used by _MAIN_LIGHT_SHADOWS_CASCADE variants
  ShadowDesc additional_shadow;
  std::vector<AdditionalLightDesc> lights;
  uint32_t tile_size = 16;                 // Forward+ tile, pixels
  // Below 1: lights are binned into tiles with a smaller range than they shade with, so a Forward+ shader that
  // reads its lists must lose light (a test of the lists being used; 1 for correct images).
  double tile_binning_range_scale = 1;
  Vec3 fog_color{0.5, 0.6, 0.7};
  double fog_density = 0.05;               // FOG_EXP, FOG_EXP2
  double fog_start = 2, fog_end = 30;      // FOG_LINEAR
  std::filesystem::path environment;       // KENV file (kiln-reference environment)
  std::filesystem::path dfg;               // KDFG table (shaderlib/data/dfg64.kdfg)
  double environment_intensity = 1;
  Vec3 glossy_environment_color{0.3, 0.3, 0.35};
  ReflectionProbe probe;
  std::vector<Object> objects;
  // The Forward variants the scene is made to judge (sorted keyword names as variant_name() writes them, "(none)"
  // for no keywords); empty: every variant. kiln test and kiln-reference goldens skip the others.
  std::vector<std::string> judged_variants;
  bool judges(const std::string& variant) const;
};

// The keyword list of a variant as goldens and reports name it: sorted, space-separated, "(none)" if empty.
std::string variant_name(const std::vector<std::string>& keywords);

// Loads a scene; throws a VerifyError (K2001) naming the bad field.
Scene load_scene(const std::filesystem::path& path);

// Mesh data: interleaved position (3), normal (3), tangent (4: xyz, w bitangent sign), uv (2).
struct Mesh {
  std::vector<float> vertices;
  std::vector<uint32_t> indices;
};
inline constexpr uint32_t kVertexFloats = 12;
Mesh make_sphere(uint32_t segments, uint32_t rings);  // unit sphere
Mesh make_plane(uint32_t cells);                     // [-1, 1]^2 in x-z, normal +y

// The shadow views a frame needs, each rendered by the ShadowCaster pass into a rectangle of an atlas.
struct ShadowView {
  Mat4 view_projection;     // clip space of the shadow camera
  Mat4 world_to_shadow;     // to atlas uv (xy) and depth (z)
  uint32_t x = 0, y = 0, size = 0;  // atlas rectangle, texels
  bool punctual = false;
  Vec3 light_position{0, 0, 0};
  Vec3 light_direction{0, 1, 0};  // towards a directional light
};

// Everything the Forward pass's constants and buffers hold for one frame, in double. `cascades` selects
// the main-light shadow layout (1: _MAIN_LIGHT_SHADOWS, 4: _MAIN_LIGHT_SHADOWS_CASCADE).
struct FrameSetup {
  Mat4 view_projection;
  Vec3 camera_forward;
  int cascades = 1;
  uint32_t main_atlas_size = 0;
  std::vector<ShadowView> main_views;       // one per cascade
  std::array<std::array<double, 4>, 4> cascade_spheres{};  // xyz center, w radius^2
  uint32_t additional_atlas_width = 0, additional_atlas_height = 0;
  std::vector<ShadowView> additional_views;  // spot: 1, point: 6 (+X -X +Y -Y +Z -Z)
  std::vector<int> light_first_shadow_view;  // per light, -1 none
  uint32_t tiles_x = 0, tiles_y = 0;
  std::vector<uint32_t> tile_lists;          // per tile: count, then indices (KILN_TILE_STRIDE)
};
inline constexpr uint32_t kMaxLightsPerTile = 63;  // shaderlib/Input.hlsl KILN_MAX_LIGHTS_PER_TILE
inline constexpr uint32_t kTileStride = kMaxLightsPerTile + 1;
FrameSetup setup_frame(const Scene& scene, int cascades);
// The main-light shadow layout a Forward variant's keywords select: the scene's cascades, or one map.
int cascades_for(const std::vector<std::string>& keywords, const Scene& scene);

Mat4 object_to_world(const Object& object);

}  // namespace kiln::render
