// SPDX-License-Identifier: Apache-2.0
#include "reference/rasterize.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "scene/image.hpp"

namespace kiln::reference {

namespace {

using render::Mat4;
using render::Vec3;

// One vertex after the vertex stage: clip position and the attributes the GBuffer pass interpolates.
struct ClipVertex {
  std::array<double, 4> clip;
  std::array<double, 10> attributes;  // world position (3), world normal (3), world tangent (3), bitangent sign
};

ClipVertex lerp(const ClipVertex& a, const ClipVertex& b, double t) {
  ClipVertex v;
  for (int i = 0; i < 4; ++i) v.clip[i] = a.clip[i] + (b.clip[i] - a.clip[i]) * t;
  for (int i = 0; i < 10; ++i) v.attributes[i] = a.attributes[i] + (b.attributes[i] - a.attributes[i]) * t;
  return v;
}

std::array<double, 3> normalized(double x, double y, double z, std::array<double, 3> fallback) {
  double length = std::sqrt(x * x + y * y + z * z);
  if (!(length > 1e-30)) return fallback;
  return {x / length, y / length, z / length};
}

// Sutherland-Hodgman against the near plane of Vulkan clip space (z >= 0, hence w > 0): the only plane a triangle
// must be clipped to; x and y beyond the viewport are skipped by the pixel loop.
std::vector<ClipVertex> clip_near(const std::array<ClipVertex, 3>& triangle) {
  std::vector<ClipVertex> out;
  for (int i = 0; i < 3; ++i) {
    const ClipVertex& a = triangle[i];
    const ClipVertex& b = triangle[(i + 1) % 3];
    const bool a_in = a.clip[2] >= 0, b_in = b.clip[2] >= 0;
    if (a_in) out.push_back(a);
    if (a_in != b_in) out.push_back(lerp(a, b, a.clip[2] / (a.clip[2] - b.clip[2])));
  }
  return out;
}

struct Sample {
  double depth = std::numeric_limits<double>::infinity();
  int object = -1;
  std::array<double, 10> attributes{};
  bool front = true;
};

struct WindowVertex {
  double x, y, z, inv_w;
  const ClipVertex* v;
};

// A viewport with its scissor: the rectangle of the target (`stride` pixels wide) that one view draws into.
struct Viewport {
  uint32_t x = 0, y = 0, width = 0, height = 0, stride = 0;
};

// Rasterizes one triangle (window coordinates) into the samples at pixel centres shifted by (dx, dy).
void rasterize(const std::array<WindowVertex, 3>& t, int object, double dx, double dy, const Viewport& view,
               std::vector<Sample>& samples) {
  const double area = (t[1].x - t[0].x) * (t[2].y - t[0].y) - (t[1].y - t[0].y) * (t[2].x - t[0].x);
  if (area == 0 || !std::isfinite(area)) return;
  // Vulkan's facing: a = -1/2 sum(x_i y_i+1 - x_i+1 y_i) in framebuffer coordinates, front (counter-clockwise,
  // the pipelines' default) when positive; `area` above is twice the opposite sign.
  const bool front = area < 0;
  const double x0 = std::min({t[0].x, t[1].x, t[2].x}), x1 = std::max({t[0].x, t[1].x, t[2].x});
  const double y0 = std::min({t[0].y, t[1].y, t[2].y}), y1 = std::max({t[0].y, t[1].y, t[2].y});
  const int px0 = std::max(int(view.x), int(std::floor(x0 - 0.5 - dx)));
  const int px1 = std::min(int(view.x + view.width) - 1, int(std::ceil(x1 - 0.5 - dx)));
  const int py0 = std::max(int(view.y), int(std::floor(y0 - 0.5 - dy)));
  const int py1 = std::min(int(view.y + view.height) - 1, int(std::ceil(y1 - 0.5 - dy)));
  for (int py = py0; py <= py1; ++py)
    for (int px = px0; px <= px1; ++px) {
      const double sx = px + 0.5 + dx, sy = py + 0.5 + dy;
      auto edge = [&](const WindowVertex& a, const WindowVertex& b) {
        return (b.x - a.x) * (sy - a.y) - (b.y - a.y) * (sx - a.x);
      };
      // Barycentric weights of vertices 0, 1, 2: the edge opposite each over the whole area.
      const double l0 = edge(t[1], t[2]) / area, l1 = edge(t[2], t[0]) / area, l2 = edge(t[0], t[1]) / area;
      if (l0 < 0 || l1 < 0 || l2 < 0) continue;
      const double depth = l0 * t[0].z + l1 * t[1].z + l2 * t[2].z;
      if (depth < 0 || depth > 1) continue;
      Sample& s = samples[size_t(py) * view.stride + px];
      if (!(depth < s.depth)) continue;
      s.depth = depth;
      s.object = object;
      s.front = front;
      // Perspective-correct: weights over w, renormalized.
      const double w0 = l0 * t[0].inv_w, w1 = l1 * t[1].inv_w, w2 = l2 * t[2].inv_w, sum = w0 + w1 + w2;
      for (int i = 0; i < 10; ++i)
        s.attributes[i] = (w0 * t[0].v->attributes[i] + w1 * t[1].v->attributes[i] + w2 * t[2].v->attributes[i]) / sum;
    }
}

// The centre and four samples around it: a pixel whose visible object differs among them is a coverage tie.
constexpr std::array<std::array<double, 2>, 5> kTieOffsets = {{{0, 0},
                                                             {kCoverageTiePixels, 0},
                                                             {-kCoverageTiePixels, 0},
                                                             {0, kCoverageTiePixels},
                                                             {0, -kCoverageTiePixels}}};
using Samples = std::array<std::vector<Sample>, kTieOffsets.size()>;

// Every object of the scene through `vertex_stage` (object, object-to-world, its inverse, mesh vertex -> clip
// vertex), clipped to the near plane and rasterized into `view` at the centre and the tie offsets.
template <typename VertexStage>
void rasterize_scene(const render::Scene& scene, const Viewport& view, VertexStage vertex_stage, Samples& samples) {
  // The renderer's meshes (verify/render/renderer.cpp): the geometry is the scene, like the positions.
  static const render::Mesh sphere = render::make_sphere(64, 32), plane = render::make_plane(32);
  for (size_t object = 0; object < scene.objects.size(); ++object) {
    const render::Object& o = scene.objects[object];
    const render::Mesh& mesh = o.shape == render::Object::Shape::Plane ? plane : sphere;
    const Mat4 world = render::object_to_world(o);
    const Mat4 world_to_object = render::mat_inverse(world);
    std::vector<ClipVertex> vertices(mesh.vertices.size() / render::kVertexFloats);
    for (size_t i = 0; i < vertices.size(); ++i)
      vertices[i] = vertex_stage(world, world_to_object, &mesh.vertices[i * render::kVertexFloats]);
    for (size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
      const std::array<ClipVertex, 3> triangle = {vertices[mesh.indices[i]], vertices[mesh.indices[i + 1]],
                                                  vertices[mesh.indices[i + 2]]};
      const std::vector<ClipVertex> polygon = clip_near(triangle);
      if (polygon.size() < 3) continue;
      std::vector<WindowVertex> window;
      for (const ClipVertex& v : polygon) {
        const double inv_w = 1 / v.clip[3];
        window.push_back({view.x + (v.clip[0] * inv_w + 1) * 0.5 * view.width,
                          view.y + (v.clip[1] * inv_w + 1) * 0.5 * view.height, v.clip[2] * inv_w, inv_w, &v});
      }
      for (size_t k = 1; k + 1 < window.size(); ++k)
        for (size_t s = 0; s < kTieOffsets.size(); ++s)
          rasterize({window[0], window[k], window[k + 1]}, int(object), kTieOffsets[s][0], kTieOffsets[s][1], view,
                    samples[s]);
    }
  }
}

// normalWS = normalize(mul(normalOS, (float3x3)_WorldToObject)): the row vector times the matrix.
std::array<double, 3> world_normal(const Mat4& world_to_object, const float* vertex) {
  double n[3];
  for (int c = 0; c < 3; ++c)
    n[c] = vertex[3] * world_to_object[0][c] + vertex[4] * world_to_object[1][c] + vertex[5] * world_to_object[2][c];
  return normalized(n[0], n[1], n[2], {0, 1, 0});
}

bool is_tie(const Samples& samples, size_t i) {
  for (size_t k = 1; k < samples.size(); ++k)
    if (samples[k][i].object != samples[0][i].object) return true;
  return false;
}

}  // namespace

render::GBuffer rasterize_gbuffer(const render::Scene& scene, const Mat4& view_projection, uint32_t width,
                                  uint32_t height) {
  Samples samples;
  for (auto& s : samples) s.assign(size_t(width) * height, Sample{});
  rasterize_scene(scene, Viewport{0, 0, width, height, width}, [&](const Mat4& world, const Mat4& world_to_object,
                                                                   const float* in) {
    auto p = render::mat_apply(world, {in[0], in[1], in[2], 1});
    ClipVertex v;
    v.clip = render::mat_apply(view_projection, p);
    auto normal = world_normal(world_to_object, in);
    auto t = render::mat_apply(world, {in[6], in[7], in[8], 0});
    auto tangent = normalized(t[0], t[1], t[2], {1, 0, 0});
    v.attributes = {p[0], p[1], p[2], normal[0], normal[1], normal[2], tangent[0], tangent[1], tangent[2],
                    in[9] < 0 ? -1.0 : 1.0};
    return v;
  }, samples);

  render::GBuffer g;
  for (render::Image* image : {&g.position, &g.normal, &g.tangent, &g.material0, &g.material1})
    *image = render::Image{width, height, std::vector<float>(size_t(width) * height * 4, 0.0f)};
  for (uint32_t y = 0; y < height; ++y)
    for (uint32_t x = 0; x < width; ++x) {
      const size_t i = size_t(y) * width + x;
      const Sample& s = samples[0][i];
      const bool tie = is_tie(samples, i);
      float* position = g.position.pixel(x, y);
      if (tie) position[3] = render::kUnstablePixel;
      if (s.object < 0) continue;
      const render::Material& m = scene.objects[size_t(s.object)].material;
      float* normal = g.normal.pixel(x, y);
      float* tangent = g.tangent.pixel(x, y);
      float* m0 = g.material0.pixel(x, y);
      float* m1 = g.material1.pixel(x, y);
      for (int c = 0; c < 3; ++c) {
        position[c] = float(s.attributes[c]);
        normal[c] = float(s.attributes[3 + c]);
        tangent[c] = float(s.attributes[6 + c]);
        m0[c] = float(m.base_color[c]);
      }
      if (!tie) position[3] = 1;
      normal[3] = s.front ? 1.0f : -1.0f;
      tangent[3] = s.attributes[9] < 0 ? -1.0f : 1.0f;
      m0[3] = float(m.metallic);
      m1[0] = float(m.perceptual_roughness);
      m1[1] = float(m.reflectance);
      m1[2] = float(m.anisotropy);
    }
  return g;
}

}  // namespace kiln::reference

namespace kiln::reference {

render::ShadowAtlas rasterize_shadow_atlas(const render::Scene& scene, const std::vector<render::ShadowView>& views,
                                           uint32_t width, uint32_t height, const render::ShadowDesc& bias) {
  Samples samples;
  for (auto& s : samples) s.assign(size_t(width) * height, Sample{});
  for (const render::ShadowView& view : views) {
    rasterize_scene(scene, Viewport{view.x, view.y, view.size, view.size, width}, [&](const Mat4& world,
                                                                                      const Mat4& world_to_object,
                                                                                      const float* in) {
      auto p4 = render::mat_apply(world, {in[0], in[1], in[2], 1});
      std::array<double, 3> p{p4[0], p4[1], p4[2]};
      const auto n = world_normal(world_to_object, in);
      // The caster-side bias (Unity's ApplyShadowBias, seed 004): away from the light by the depth bias, and into
      // the surface by the normal bias, scaled by how far the surface turns from the light.
      std::array<double, 3> l = view.light_direction;
      if (view.punctual)
        l = normalized(view.light_position[0] - p[0], view.light_position[1] - p[1], view.light_position[2] - p[2], n);
      const double NoL = std::clamp(l[0] * n[0] + l[1] * n[1] + l[2] * n[2], 0.0, 1.0);
      const double normal_offset = (1 - NoL) * bias.caster_normal_bias;
      for (int c = 0; c < 3; ++c) p[c] += -l[c] * bias.caster_depth_bias - n[c] * normal_offset;
      ClipVertex v;
      v.clip = render::mat_apply(view.view_projection, {p[0], p[1], p[2], 1});
      v.attributes = {};
      return v;
    }, samples);
  }
  render::ShadowAtlas atlas{width, height, std::vector<float>(size_t(width) * height, 1.0f), {}, {}};
  atlas.tie.assign(atlas.depth.size(), 0);
  atlas.depth_tolerance.assign(atlas.depth.size(), 0.0f);
  for (size_t i = 0; i < atlas.depth.size(); ++i) {
    if (samples[0][i].object >= 0) atlas.depth[i] = float(samples[0][i].depth);
    atlas.tie[i] = is_tie(samples, i);
    if (atlas.tie[i] || samples[0][i].object < 0) continue;
    double spread = 0;
    for (const auto& s : samples) spread = std::max(spread, std::abs(s[i].depth - samples[0][i].depth));
    atlas.depth_tolerance[i] = float(spread);
  }
  return atlas;
}

}  // namespace kiln::reference
