// SPDX-License-Identifier: Apache-2.0
#include "reference/scene_reference.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace kiln::reference {
namespace {

Vec3 cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
Vec3 from(const render::Vec3& v) { return {v[0], v[1], v[2]}; }
double saturate(double x) { return std::clamp(x, 0.0, 1.0); }
double length_squared(Vec3 v) { return dot(v, v); }
Vec3 safe_normalize(Vec3 v, Vec3 fallback) { return length_squared(v) > 1e-20 ? normalize(v) : fallback; }
using Rgb = std::array<double, 3>;

bool has(const std::vector<std::string>& keywords, const char* k) {
  return std::find(keywords.begin(), keywords.end(), k) != keywords.end();
}

// Vulkan's cube face selection and face coordinates (spec table "Cube map face selection").
void cube_face(Vec3 d, int& face, double& s, double& t) {
  double ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z), sc, tc, ma;
  if (ax >= ay && ax >= az) {
    face = d.x >= 0 ? 0 : 1;
    ma = ax;
    sc = d.x >= 0 ? -d.z : d.z;
    tc = -d.y;
  } else if (ay >= az) {
    face = d.y >= 0 ? 2 : 3;
    ma = ay;
    sc = d.x;
    tc = d.y >= 0 ? d.z : -d.z;
  } else {
    face = d.z >= 0 ? 4 : 5;
    ma = az;
    sc = d.z >= 0 ? d.x : -d.x;
    tc = -d.y;
  }
  s = 0.5 * (sc / ma + 1);
  t = 0.5 * (tc / ma + 1);
}

Vec3 cube_direction(int face, double s, double t) {
  double sc = 2 * s - 1, tc = 2 * t - 1;
  switch (face) {
    case 0: return normalize({1, -tc, -sc});
    case 1: return normalize({-1, -tc, sc});
    case 2: return normalize({sc, 1, tc});
    case 3: return normalize({sc, -1, -tc});
    case 4: return normalize({sc, -tc, 1});
    default: return normalize({-sc, -tc, -1});
  }
}

// Box projection, as a ray tracer finds it: the ray P + t R leaves the box where it crosses the first of the three
// slabs' far planes (per axis, the plane R points towards); the cubemap, captured at the probe, is sampled towards
// that exit point. A shading point outside the box (t < 0) looks from where it is.
Vec3 box_projected(const render::ReflectionProbe& probe, const Vec3& P, const Vec3& R) {
  const Vec3 lo = from(probe.box_min), hi = from(probe.box_max);
  double exit = std::numeric_limits<double>::infinity();
  for (auto [p, r, low, high] : {std::array{P.x, R.x, lo.x, hi.x}, std::array{P.y, R.y, lo.y, hi.y}, std::array{P.z, R.z, lo.z, hi.z}}) {
    if (r == 0) continue;  // parallel to this slab: never leaves through it
    exit = std::min(exit, ((r > 0 ? high : low) - p) / r);
  }
  return P + R * std::max(exit, 0.0) - from(probe.position);
}

// Trilinear cube sampling with seamless filtering (Vulkan always filters across cube faces): a bilinear tap
// that falls outside its face is replaced by the texel of the neighbouring face that its centre direction
// lands on. The reference's own texture unit; corner taps take the nearest of the three corner texels.
Rgb sample_cube(const render::Environment& env, Vec3 d, double lod) {
  lod = std::clamp(lod, 0.0, double(env.mips - 1));
  int m0 = static_cast<int>(std::floor(lod));
  int m1 = std::min(m0 + 1, int(env.mips) - 1);
  double w = lod - m0;
  int face;
  double s, t;
  cube_face(d, face, s, t);
  auto level = [&](int m) {
    int n = static_cast<int>(env.level_size(m));
    double x = s * n - 0.5, y = t * n - 0.5;
    int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
    double fx = x - x0, fy = y - y0;
    Rgb out{};
    for (int dy = 0; dy <= 1; ++dy)
      for (int dx = 0; dx <= 1; ++dx) {
        int xi = x0 + dx, yi = y0 + dy, f = face;
        if (xi < 0 || xi >= n || yi < 0 || yi >= n) {
          double ts, tt;
          cube_face(cube_direction(face, (xi + 0.5) / n, (yi + 0.5) / n), f, ts, tt);
          xi = static_cast<int>(std::floor(ts * n));
          yi = static_cast<int>(std::floor(tt * n));
        }
        xi = std::clamp(xi, 0, n - 1);
        yi = std::clamp(yi, 0, n - 1);
        double weight = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy);
        const float* texel = &env.levels[m][((size_t(f) * n + yi) * n + xi) * 4];
        for (int c = 0; c < 3; ++c) out[c] += weight * texel[c];
      }
    return out;
  };
  Rgb a = level(m0);
  if (w == 0 || m1 == m0) return a;
  Rgb b = level(m1);
  return {a[0] + (b[0] - a[0]) * w, a[1] + (b[1] - a[1]) * w, a[2] + (b[2] - a[2]) * w};
}

Rgb sh9_irradiance_over_pi(const render::Environment& env, Vec3 n) {
  const double basis[9] = {1,           n.y,         n.z,
                           n.x,         n.x * n.y,   n.y * n.z,
                           3 * n.z * n.z - 1, n.x * n.z, n.x * n.x - n.y * n.y};
  Rgb r{};
  for (int i = 0; i < 9; ++i)
    for (int c = 0; c < 3; ++c) r[c] += env.sh[i][c] * basis[i];
  for (double& v : r) v = std::max(v, 0.0);
  return r;
}

// One nearest texel's depth test, as a comparison sampler with LESS_OR_EQUAL and nearest filtering does.
double shadow_tap(const render::ShadowAtlas& atlas, double u, double v, double z) {
  if (u < 0 || u > 1 || v < 0 || v > 1 || z > 1 || z < 0) return 1;
  int x = std::clamp(static_cast<int>(std::floor(u * atlas.width)), 0, int(atlas.width) - 1);
  int y = std::clamp(static_cast<int>(std::floor(v * atlas.height)), 0, int(atlas.height) - 1);
  return z <= atlas.depth[size_t(y) * atlas.width + x] ? 1.0 : 0.0;
}

// A tap whose result changes when its inputs move by far less than a texel (1/100) or a depth step (2e-6):
// the GPU computes those inputs in fp32 (the hard-shadow coordinate even per vertex), so either result is
// right there. Such pixels are marked unstable and left out of the comparison (see kiln test).
// The reference's own atlases also mark texels whose caster is a coverage tie (a tap reading one is unstable too)
// and widen the depth step to how far a texel's depth moves within the tie distance (GPUs snap vertices).
bool shadow_tap_is_unstable(const render::ShadowAtlas& atlas, double u, double v, double z) {
  const double du = 0.01 / atlas.width, dv = 0.01 / atlas.height;
  double center = shadow_tap(atlas, u, v, z);
  // Most taps are well inside one texel: then the nine (u, v) offsets below read the same texel with the same depth
  // step, and three depth taps decide (the same answer as the full search, at a ninth of its cost).
  auto column = [&](double t) { return std::clamp(static_cast<int>(std::floor(t * atlas.width)), 0, int(atlas.width) - 1); };
  auto row = [&](double t) { return std::clamp(static_cast<int>(std::floor(t * atlas.height)), 0, int(atlas.height) - 1); };
  if (u - du >= 0 && u + du <= 1 && v - dv >= 0 && v + dv <= 1 && column(u - du) == column(u + du) &&
      row(v - dv) == row(v + dv)) {
    double dz = 2e-6;
    if (!atlas.tie.empty()) {
      const size_t texel = size_t(row(v)) * atlas.width + column(u);
      if (atlas.tie[texel]) return true;
      dz = std::max(dz, 2e-6 + double(atlas.depth_tolerance[texel]));
    }
    return shadow_tap(atlas, u, v, z - dz) != center || shadow_tap(atlas, u, v, z + dz) != center;
  }
  for (double ou : {-du, 0.0, du})
    for (double ov : {-dv, 0.0, dv}) {
      const double tu = u + ou, tv = v + ov;
      double dz = 2e-6;
      if (!atlas.tie.empty() && tu >= 0 && tu <= 1 && tv >= 0 && tv <= 1) {
        int x = std::clamp(static_cast<int>(std::floor(tu * atlas.width)), 0, int(atlas.width) - 1);
        int y = std::clamp(static_cast<int>(std::floor(tv * atlas.height)), 0, int(atlas.height) - 1);
        const size_t texel = size_t(y) * atlas.width + x;
        if (atlas.tie[texel]) return true;
        dz = std::max(dz, 2e-6 + double(atlas.depth_tolerance[texel]));
      }
      for (double oz : {-dz, 0.0, dz})
        if (shadow_tap(atlas, tu, tv, z + oz) != center) return true;
    }
  return false;
}

double shadow_visibility(const render::ShadowAtlas& atlas, std::array<double, 3> coord, double strength, double bias,
                         bool soft, bool& unstable) {
  double z = coord[2] - bias;
  double visibility;
  if (soft) {
    double texel = 1.0 / atlas.width, sum = 0;
    for (int y = -1; y <= 1; ++y)
      for (int x = -1; x <= 1; ++x) {
        double u = coord[0] + x * texel, v = coord[1] + y * texel;
        sum += (x == 0 ? 2 : 1) * (y == 0 ? 2 : 1) * shadow_tap(atlas, u, v, z);
        unstable = unstable || shadow_tap_is_unstable(atlas, u, v, z);
      }
    visibility = sum / 16;
  } else {
    visibility = shadow_tap(atlas, coord[0], coord[1], z);
    unstable = unstable || shadow_tap_is_unstable(atlas, coord[0], coord[1], z);
  }
  return 1 + (visibility - 1) * strength;
}

std::array<double, 4> transform(const render::Mat4& m, Vec3 p) { return render::mat_apply(m, {p.x, p.y, p.z, 1}); }

struct Model {
  bool burley, anisotropic, mobile, env_approx, multiscatter, specular_off, reflections_off, half;
};

struct Surface {
  Rgb diffuse_color, f0, specular_albedo, energy;
  double perceptual_roughness, alpha, at, ab, NoV;
  Vec3 N, T, B, V;
};

// BRDF x NoL per unit illuminance from L (shaderlib's DirectBRDF, re-derived from the papers' formulas).
Rgb direct(const Model& m, const Surface& s, Vec3 L) {
  double NoL = saturate(dot(s.N, L));
  if (NoL <= 0) return {0, 0, 0};
  Vec3 H = safe_normalize(L + s.V, s.N);
  double NoH = saturate(dot(s.N, H)), LoH = saturate(dot(L, H));
  Rgb out{};
  if (m.mobile) {
    // Unity's mobile BRDF (BRDF2): Blinn-Phong normalized as (n + 1) NoH^n, Kelemen visibility approximation.
    double r = s.perceptual_roughness;
    double n = std::max(2.0 / std::max(1e-4, r * r * r * r) - 2.0, 1e-4);
    double invV = LoH * LoH * (1 - r) + r * r;
    double specular = m.specular_off ? 0 : (n + 1) * std::pow(std::max(NoH, 1e-4), n) / (8 * invV * LoH + 1e-4);
    for (int c = 0; c < 3; ++c) out[c] = (s.diffuse_color[c] + specular * s.f0[c]) * NoL / kPi;
    return out;
  }
  double fd = m.burley ? Fd_RenormalizedBurley(s.NoV, NoL, LoH, s.perceptual_roughness) : Fd_Lambert();
  double dv;
  if (m.anisotropic) {
    dv = D_GGX_Anisotropic(NoH, dot(s.T, H), dot(s.B, H), s.at, s.ab) *
         V_SmithGGXCorrelated_Anisotropic(s.at, s.ab, dot(s.T, s.V), dot(s.B, s.V), dot(s.T, L), dot(s.B, L), s.NoV, NoL);
  } else {
    dv = D_GGX(NoH, s.alpha) * V_SmithGGXCorrelated(s.NoV, NoL, s.alpha);
  }
  for (int c = 0; c < 3; ++c) {
    double F = F_Schlick(s.f0[c], 1.0, LoH);
    double specular = m.specular_off ? 0 : dv * F * s.energy[c];
    out[c] = (s.diffuse_color[c] * fd * (1 - F) + specular) * NoL;
  }
  return out;
}

// The environment's light integrated over the hemisphere for one surface, by Monte Carlo over the analytic sky:
// the split-sum, SH9 and DFG-table approximations the shader (and the table-sampling reference) make are absent.
struct IntegratedEnvironment {
  bool valid = false;
  Rgb specular{};         // (1/N) sum of 4 Vis F NoL VoH / NoH * L(l), GGX-importance sampled
  Rgb specular_albedo{};  // the same with L = 1: what the shader takes from the DFG table
  double albedo = 0;      // the same with F = 1 (energy compensation's E)
  Rgb irradiance{};       // (1/pi) integral of L cos: cosine-sampled
};

// A per-pixel rotation of the Hammersley points (Cranley-Patterson): noise, not structure, across pixels.
std::array<double, 2> pixel_offset(uint32_t x, uint32_t y, uint32_t salt) {
  uint64_t h = (uint64_t(x) * 0x9E3779B97F4A7C15ull) ^ (uint64_t(y) * 0xC2B2AE3D27D4EB4Full) ^ (uint64_t(salt) * 0x165667B19E3779F9ull);
  h ^= h >> 33, h *= 0xFF51AFD7ED558CCDull, h ^= h >> 33, h *= 0xC4CEB9FE1A85EC53ull, h ^= h >> 33;
  return {double(h >> 40) / double(1ull << 24), double(h & 0xFFFFFF) / double(1ull << 24)};
}

IntegratedEnvironment integrate_environment(const Surface& s, uint32_t samples, std::array<double, 2> offset) {
  IntegratedEnvironment out;
  out.valid = true;
  Vec3 up = std::abs(s.N.z) < 0.999 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
  Vec3 tx = normalize(cross(up, s.N)), ty = cross(s.N, tx);
  auto rotated = [&](uint32_t i, uint32_t n) {
    auto u = hammersley(i, n);
    return std::array<double, 2>{std::fmod(u[0] + offset[0], 1.0), std::fmod(u[1] + offset[1], 1.0)};
  };
  const double a2 = s.alpha * s.alpha;
  for (uint32_t i = 0; i < samples; ++i) {
    auto u = rotated(i, samples);
    double phi = 2 * kPi * u[0];
    double cos_theta = std::sqrt((1 - u[1]) / (1 + (a2 - 1) * u[1]));
    double sin_theta = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
    Vec3 H = tx * (sin_theta * std::cos(phi)) + ty * (sin_theta * std::sin(phi)) + s.N * cos_theta;
    double VoH = dot(s.V, H);
    Vec3 L = H * (2 * VoH) - s.V;
    double NoL = dot(s.N, L), NoH = dot(s.N, H);
    if (NoL <= 0 || VoH <= 0 || NoH <= 0) continue;
    double w = 4 * V_SmithGGXCorrelated(s.NoV, NoL, s.alpha) * NoL * VoH / NoH;
    Rgb radiance = SkyRadiance(normalize(L));
    out.albedo += w;
    for (int c = 0; c < 3; ++c) {
      double F = F_Schlick(s.f0[c], 1.0, VoH);
      out.specular[c] += w * F * radiance[c];
      out.specular_albedo[c] += w * F;
    }
  }
  out.albedo /= samples;
  for (int c = 0; c < 3; ++c) out.specular[c] /= samples, out.specular_albedo[c] /= samples;
  const uint32_t diffuse_samples = std::max(1u, samples / 4);
  for (uint32_t i = 0; i < diffuse_samples; ++i) {
    auto u = rotated(i, diffuse_samples);
    double phi = 2 * kPi * u[0], r = std::sqrt(u[1]);
    Vec3 L = tx * (r * std::cos(phi)) + ty * (r * std::sin(phi)) + s.N * std::sqrt(std::max(0.0, 1 - u[1]));
    Rgb radiance = SkyRadiance(normalize(L));
    for (int c = 0; c < 3; ++c) out.irradiance[c] += radiance[c] / diffuse_samples;
  }
  return out;
}

int cube_face_index(Vec3 d) {
  double ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z);
  if (ax >= ay && ax >= az) return d.x >= 0 ? 0 : 1;
  if (ay >= az) return d.y >= 0 ? 2 : 3;
  return d.z >= 0 ? 4 : 5;
}

}  // namespace

std::array<double, 3> SkyRadiance(const Vec3& d) {
  const Vec3 sun = normalize({0.35, 0.6, 0.7});
  double up = d.y;
  Rgb zenith{0.18, 0.34, 0.85}, horizon{0.75, 0.8, 0.9}, ground{0.22, 0.19, 0.16};
  Rgb sky;
  if (up >= 0) {
    double t = std::sqrt(up);
    for (int c = 0; c < 3; ++c) sky[c] = horizon[c] + (zenith[c] - horizon[c]) * t;
  } else {
    double t = std::min(1.0, -up * 4);  // a short blend below the horizon: no hard edge to alias
    for (int c = 0; c < 3; ++c) sky[c] = horizon[c] + (ground[c] - horizon[c]) * t;
  }
  double glow = std::pow(std::max(dot(d, sun), 0.0), 24.0);
  Rgb sun_color{2.4, 2.1, 1.6};
  for (int c = 0; c < 3; ++c) sky[c] += sun_color[c] * glow;
  return sky;
}

render::Environment make_environment(uint32_t size, uint32_t mips, uint32_t samples) {
  render::Environment env;
  env.size = size;
  env.mips = mips;
  for (uint32_t m = 0; m < mips; ++m) {
    uint32_t n = env.level_size(m);
    double roughness = mips > 1 ? double(m) / (mips - 1) : 0;
    double a = roughness * roughness;
    std::vector<float> level(size_t(6) * n * n * 4);
    for (int face = 0; face < 6; ++face)
      for (uint32_t y = 0; y < n; ++y)
        for (uint32_t x = 0; x < n; ++x) {
          Vec3 N = cube_direction(face, (x + 0.5) / n, (y + 0.5) / n);
          Rgb sum{};
          double weight = 0;
          if (m == 0) {
            sum = SkyRadiance(N);
            weight = 1;
          } else {
            // N = V = R (Karis 2013), GGX-distributed half vectors, weighted by NoL.
            Vec3 up = std::abs(N.z) < 0.999 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
            Vec3 tx = normalize(cross(up, N)), ty = cross(N, tx);
            for (uint32_t i = 0; i < samples; ++i) {
              auto u = hammersley(i, samples);
              double phi = 2 * kPi * u[0];
              double cos_theta = std::sqrt((1 - u[1]) / (1 + (a * a - 1) * u[1]));
              double sin_theta = std::sqrt(1 - cos_theta * cos_theta);
              Vec3 H = tx * (sin_theta * std::cos(phi)) + ty * (sin_theta * std::sin(phi)) + N * cos_theta;
              Vec3 L = H * (2 * dot(N, H)) - N;
              double NoL = dot(N, L);
              if (NoL <= 0) continue;
              Rgb radiance = SkyRadiance(normalize(L));
              for (int c = 0; c < 3; ++c) sum[c] += radiance[c] * NoL;
              weight += NoL;
            }
          }
          float* texel = &level[((size_t(face) * n + y) * n + x) * 4];
          for (int c = 0; c < 3; ++c) texel[c] = static_cast<float>(sum[c] / weight);
          texel[3] = 1;
        }
    env.levels.push_back(std::move(level));
  }
  // SH projection by midpoint quadrature over (theta, phi), then the cosine-lobe convolution / pi.
  const int rows = 256, columns = 512;
  double L[9][3] = {};
  for (int i = 0; i < rows; ++i) {
    double theta = kPi * (i + 0.5) / rows;
    for (int j = 0; j < columns; ++j) {
      double phi = 2 * kPi * (j + 0.5) / columns;
      Vec3 d{std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)};
      double dw = (kPi / rows) * (2 * kPi / columns) * std::sin(theta);
      const double Y[9] = {0.282095,           0.488603 * d.y,           0.488603 * d.z,
                           0.488603 * d.x,     1.092548 * d.x * d.y,     1.092548 * d.y * d.z,
                           0.315392 * (3 * d.z * d.z - 1), 1.092548 * d.x * d.z, 0.546274 * (d.x * d.x - d.y * d.y)};
      Rgb radiance = SkyRadiance(d);
      for (int k = 0; k < 9; ++k)
        for (int c = 0; c < 3; ++c) L[k][c] += radiance[c] * Y[k] * dw;
    }
  }
  // A_l / pi = 1, 2/3, 1/4; times the basis constants, since SampleSH9 evaluates bare polynomials.
  const double factor[9] = {0.282095,          2.0 / 3 * 0.488603, 2.0 / 3 * 0.488603,
                            2.0 / 3 * 0.488603, 0.25 * 1.092548,   0.25 * 1.092548,
                            0.25 * 0.315392,   0.25 * 1.092548,   0.25 * 0.546274};
  for (int k = 0; k < 9; ++k)
    for (int c = 0; c < 3; ++c) env.sh[k][c] = static_cast<float>(L[k][c] * factor[k]);
  return env;
}

std::vector<std::string> reference_key(const std::vector<std::string>& keywords) {
  std::vector<std::string> key;
  for (const auto& k : keywords)
    if (k != "_FORWARD_PLUS") key.push_back(k);
  return key;
}

render::Image shade_image(const ReferenceInputs& in, const std::vector<std::string>& kw) {
  const render::Scene& scene = *in.scene;
  const render::GBuffer& g = *in.gbuffer;
  Model m{};
  m.mobile = has(kw, "_MOBILE_BRDF");
  m.burley = has(kw, "_DIFFUSE_BURLEY");
  m.anisotropic = has(kw, "_ANISOTROPY") && !m.mobile;
  m.env_approx = has(kw, "_ENV_BRDF_APPROX") || m.mobile;
  m.multiscatter = has(kw, "_MULTISCATTER") && !m.env_approx;
  m.specular_off = has(kw, "_SPECULARHIGHLIGHTS_OFF");
  m.reflections_off = has(kw, "_ENVIRONMENTREFLECTIONS_OFF");
  m.half = has(kw, "_HALF_PRECISION");
  const bool hard = has(kw, "_MAIN_LIGHT_SHADOWS"), cascaded = has(kw, "_MAIN_LIGHT_SHADOWS_CASCADE");
  const bool soft = has(kw, "_SHADOWS_SOFT");
  const bool per_pixel = has(kw, "_ADDITIONAL_LIGHTS"), per_vertex = has(kw, "_ADDITIONAL_LIGHTS_VERTEX");
  const bool light_shadows = has(kw, "_ADDITIONAL_LIGHT_SHADOWS");
  const bool fog_linear = has(kw, "FOG_LINEAR"), fog_exp = has(kw, "FOG_EXP"), fog_exp2 = has(kw, "FOG_EXP2");
  const bool linear_output = has(kw, "_LINEAR_OUTPUT");
  // The roughness floor is part of each precision's model (shaderlib/Common.hlsl): fp16 needs 0.089.
  const double min_roughness = m.half ? 0.089 : 0.045;

  const Vec3 camera = from(scene.camera_position);
  const Vec3 sun = normalize(from(scene.main_light_direction));
  const Rgb sun_illuminance{scene.main_light_color[0] * scene.main_light_illuminance,
                            scene.main_light_color[1] * scene.main_light_illuminance,
                            scene.main_light_color[2] * scene.main_light_illuminance};
  const Vec3 forward = from(in.frame->camera_forward);

  render::Image out{g.position.width, g.position.height, std::vector<float>(g.position.rgba.size(), 0.0f)};
  for (uint32_t y = 0; y < out.height; ++y)
    for (uint32_t x = 0; x < out.width; ++x) {
      const float* p = g.position.pixel(x, y);
      float* o = out.pixel(x, y);
      o[3] = 1;
      if (p[3] == 0 || p[3] == render::kUnstablePixel) {
        o[3] = p[3];  // background, or a coverage tie (which surface the GPU draws there is a rounding matter)
        continue;
      }
      const float* nrm = g.normal.pixel(x, y);
      const float* tan = g.tangent.pixel(x, y);
      const float* m0 = g.material0.pixel(x, y);
      const float* m1 = g.material1.pixel(x, y);
      Vec3 P{p[0], p[1], p[2]};
      Surface s{};
      s.N = safe_normalize({nrm[0], nrm[1], nrm[2]}, {0, 1, 0}) * (nrm[3] < 0 ? -1.0 : 1.0);
      s.V = safe_normalize(camera - P, s.N);
      if (m.anisotropic) {
        Vec3 t{tan[0], tan[1], tan[2]};
        t = t - s.N * dot(s.N, t);
        s.T = safe_normalize(t, std::abs(s.N.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 0, 1});
        s.B = cross(s.N, s.T) * (tan[3] < 0 ? -1.0 : 1.0);
      }
      const Rgb base{m0[0], m0[1], m0[2]};
      const double metallic = m0[3], authored_roughness = m1[0], reflectance = m1[1];
      const double anisotropy = m.anisotropic ? std::clamp(double(m1[2]), -1.0, 1.0) : 0.0;
      s.perceptual_roughness = std::clamp(authored_roughness, min_roughness, 1.0);
      s.alpha = s.perceptual_roughness * s.perceptual_roughness;
      s.at = std::max(s.alpha * (1 + anisotropy), min_roughness * min_roughness);
      s.ab = std::max(s.alpha * (1 - anisotropy), min_roughness * min_roughness);
      s.NoV = std::max(dot(s.N, s.V), 1e-4);
      // The DFG table holds the lobe the BRDF evaluates: looked up at the clamped roughness (shaderlib/IBL.hlsl).
      auto dfg = in.dfg->sample(s.NoV, s.perceptual_roughness);
      auto approx = EnvBRDFApprox(s.perceptual_roughness, s.NoV);
      for (int c = 0; c < 3; ++c) {
        s.diffuse_color[c] = base[c] * (1 - metallic);
        s.f0[c] = ComputeF0(base[c], metallic, reflectance);
        s.specular_albedo[c] = m.env_approx ? saturate(s.f0[c] * approx[0] + approx[1])
                                            : dfg[0] + (dfg[1] - dfg[0]) * s.f0[c];
        s.energy[c] = m.multiscatter ? 1 + s.f0[c] * (1 / std::max(dfg[1], 1e-3) - 1) : 1;
      }
      IntegratedEnvironment integrated;
      if (in.integrate_environment_samples > 0 && !m.anisotropic && !m.mobile && !m.env_approx) {
        integrated = integrate_environment(s, in.integrate_environment_samples, pixel_offset(x, y, in.sample_salt));
        for (int c = 0; c < 3; ++c) {
          s.specular_albedo[c] = integrated.specular_albedo[c];
          s.energy[c] = m.multiscatter ? 1 + s.f0[c] * (1 / std::max(integrated.albedo, 1e-3) - 1) : 1;
        }
      }

      Rgb color{};
      bool unstable = false;
      // Main light and its shadow.
      double visibility = 1;
      if (hard || cascaded) {
        int cascade = 0;
        if (cascaded) {
          cascade = -1;
          for (int i = 0; i < int(in.frame->main_views.size()); ++i) {
            const auto& sphere = in.frame->cascade_spheres[i];
            Vec3 d = P - Vec3{sphere[0], sphere[1], sphere[2]};
            if (dot(d, d) <= sphere[3]) {
              cascade = i;
              break;
            }
          }
        }
        if (cascade >= 0) {
          auto c = transform(in.frame->main_views[cascade].world_to_shadow, P);
          visibility = shadow_visibility(*in.main_shadow, {c[0] / c[3], c[1] / c[3], c[2] / c[3]},
                                         scene.main_shadow.strength, scene.main_shadow.receiver_depth_bias, soft, unstable);
        }
      }
      Rgb f = direct(m, s, sun);
      for (int c = 0; c < 3; ++c) color[c] += f[c] * sun_illuminance[c] * visibility;

      // Additional lights: per pixel (plain loop and Forward+ alike: every light, range-windowed), or
      // per vertex, which the reference evaluates per pixel (the tolerance file states the bound).
      const size_t count = per_pixel ? scene.lights.size() : per_vertex ? std::min<size_t>(scene.lights.size(), 8) : 0;
      Rgb vertex_irradiance{};
      for (size_t i = 0; i < count; ++i) {
        const render::AdditionalLightDesc& light = scene.lights[i];
        Vec3 to_light = from(light.position) - P;
        double d2 = dot(to_light, to_light);
        Vec3 L = safe_normalize(to_light, {0, 1, 0});
        double attenuation = DistanceAttenuation(d2, 1.0 / (light.range * light.range));
        if (light.spot)
          attenuation *= SpotAttenuation(-dot(L, from(light.direction)), std::cos(light.inner_degrees * kPi / 180),
                                         std::cos(light.outer_degrees * kPi / 180));
        Rgb radiance{light.color[0] * light.intensity * attenuation, light.color[1] * light.intensity * attenuation,
                     light.color[2] * light.intensity * attenuation};
        if (per_vertex) {
          for (int c = 0; c < 3; ++c) vertex_irradiance[c] += radiance[c] * saturate(dot(s.N, L));
          continue;
        }
        double shadow = 1;
        int first = in.additional_frame->light_first_shadow_view[i];
        if (light_shadows && first >= 0) {
          int view = first + (light.spot ? 0 : cube_face_index(P - from(light.position)));
          auto c = transform(in.additional_frame->additional_views[view].world_to_shadow, P);
          if (c[3] > 1e-6)
            shadow = shadow_visibility(*in.additional_shadow, {c[0] / c[3], c[1] / c[3], c[2] / c[3]},
                                       scene.additional_shadow.strength, scene.additional_shadow.receiver_depth_bias, soft, unstable);
        }
        Rgb fl = direct(m, s, L);
        for (int c = 0; c < 3; ++c) color[c] += fl[c] * radiance[c] * shadow;
      }
      for (int c = 0; c < 3; ++c) color[c] += s.diffuse_color[c] * vertex_irradiance[c] / kPi;

      // Image-based lighting: SH irradiance, prefiltered radiance (or the flat glossy color); or the sky integrated.
      Rgb irradiance = integrated.valid ? integrated.irradiance : sh9_irradiance_over_pi(*in.environment, s.N);
      Rgb prefiltered;
      if (integrated.valid && !m.reflections_off) {
        // The integral already holds F and the lobe: prefiltered x specular albedo, without the split.
        for (int c = 0; c < 3; ++c)
          prefiltered[c] = integrated.specular_albedo[c] > 0 ? integrated.specular[c] / integrated.specular_albedo[c] : 0;
      } else if (m.reflections_off) {
        prefiltered = {scene.glossy_environment_color[0], scene.glossy_environment_color[1], scene.glossy_environment_color[2]};
      } else {
        Vec3 R = s.N * (2 * dot(s.N, s.V)) - s.V;
        if (scene.probe.box_projection) R = box_projected(scene.probe, P, R);
        prefiltered = sample_cube(*in.environment, R, saturate(authored_roughness) * (in.environment->mips - 1));
      }
      for (int c = 0; c < 3; ++c) {
        double k = scene.environment_intensity;
        color[c] += s.diffuse_color[c] * irradiance[c] * k * (1 - s.specular_albedo[c]) +
                    prefiltered[c] * k * s.specular_albedo[c] * s.energy[c];
      }

      // Fog on view depth, exposure, tone mapping.
      if (fog_linear || fog_exp || fog_exp2) {
        double depth = std::max(dot(P - camera, forward), 0.0);
        double factor = fog_linear ? FogFactorLinear(depth, scene.fog_start, scene.fog_end)
                        : fog_exp  ? FogFactorExp(depth, scene.fog_density)
                                   : FogFactorExp2(depth, scene.fog_density);
        for (int c = 0; c < 3; ++c) color[c] = MixFog(color[c], scene.fog_color[c], factor);
      }
      for (double& v : color) v *= scene.exposure;
      if (!linear_output) color = ACESFitted(color);
      for (int c = 0; c < 3; ++c) o[c] = static_cast<float>(color[c]);
      if (unstable) o[3] = render::kUnstablePixel;
    }
  return out;
}

}  // namespace kiln::reference
