// SPDX-License-Identifier: Apache-2.0
// Shading cost against error for every approximation shaderlib offers (issue 3, part 2).
//
// Error: each term is compiled by kiln's front end and SPIRV-Tools (tests/gpu/Probe.hlsl, PROBE_TERM) and run
// on lavapipe over a dense grid; its GPU output is compared with the double-precision CPU reference
// (verify/reference): the exact formula, or the Monte-Carlo ground truth (DFG integrals, directional albedo).
// Cost: weighted instruction count of the optimized SPIR-V (primary; weights in lavapipe.hpp) minus the
// empty probe's; lavapipe wall time as a secondary axis with its spread.
//
// usage: kiln-shading-study OUT.json
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "probe/lavapipe.hpp"
#include "reference/reference.hpp"
#include "reflect/reflect.hpp"

namespace ref = kiln::reference;
using kiln::gpu::ProbeInput;
using kiln::gpu::ProbeOutput;
using kiln::gpu::ProbeBuffer;
using kiln::gpu::ProbeTexture;

namespace {

const std::filesystem::path kRoot = KILN_SOURCE_DIR;
const std::filesystem::path kProbe = kRoot / "tests/gpu/Probe.hlsl";

std::vector<double> linspace(double a, double b, int n) {
  std::vector<double> v;
  for (int i = 0; i < n; ++i) v.push_back(n == 1 ? a : a + (b - a) * i / (n - 1));
  return v;
}

// One grid point: the probe record and the ground truth for it.
struct Point {
  ProbeInput input{};
  double truth = 0;
  bool fp16_domain = true;  // r >= 0.089: below it fp16 evaluates a different (clamped) lobe by design
  double albedo = 0;        // white furnace only: single-scattering E(f0 = 1) by Monte Carlo
};

struct Member {
  std::string name;
  std::vector<std::string> defines;
  std::optional<ProbeTexture> texture;
  std::string note;
  std::vector<std::string> cost_defines;  // when set, the fragment cost is measured on this probe instead
  double lights_per_pixel = 0;            // Forward+ family: mean loop iterations per pixel
};

// The Forward+ scene: lights over a 6.4 m x 6.4 m ground patch seen as 128 x 128 pixels, 16-pixel tiles.
struct LightScene {
  static constexpr int kPixels = 128;
  static constexpr double kMetersPerPixel = 0.05;
  static constexpr int kTilePixels = 16;
  static constexpr int kTiles = kPixels / kTilePixels;
  static constexpr int kStride = 64;  // KILN_TILE_STRIDE in shaderlib/Input.hlsl
  static constexpr double kRange = 1.0;
  struct Light {
    double x, y, z, intensity;
  };
  std::vector<Light> lights;
  std::vector<uint32_t> tiles;  // [count, index...] per tile, kStride words each
  double mean_list = 0;
};

LightScene make_light_scene(int count) {
  LightScene scene;
  uint32_t state = 12345;  // deterministic LCG: the scene is the same in every run
  auto next = [&] {
    state = state * 1664525u + 1013904223u;
    return (state >> 8) / double(1u << 24);
  };
  const double size = LightScene::kPixels * LightScene::kMetersPerPixel;
  for (int i = 0; i < count; ++i)
    scene.lights.push_back({next() * size, 0.3 + 0.6 * next(), next() * size, 1.0 + 4.0 * next()});
  // Conservative tile lists: a light is listed if its range sphere reaches the tile's rectangle on the plane.
  const double tile = LightScene::kTilePixels * LightScene::kMetersPerPixel;
  size_t listed = 0;
  for (int ty = 0; ty < LightScene::kTiles; ++ty)
    for (int tx = 0; tx < LightScene::kTiles; ++tx) {
      std::vector<uint32_t> list;
      for (size_t i = 0; i < scene.lights.size(); ++i) {
        const auto& l = scene.lights[i];
        double dx = std::max({tx * tile - l.x, 0.0, l.x - (tx + 1) * tile});
        double dz = std::max({ty * tile - l.z, 0.0, l.z - (ty + 1) * tile});
        if (dx * dx + dz * dz + l.y * l.y <= LightScene::kRange * LightScene::kRange) list.push_back(uint32_t(i));
      }
      if (list.size() > LightScene::kStride - 1) list.resize(LightScene::kStride - 1);
      listed += list.size();
      scene.tiles.push_back(uint32_t(list.size()));
      list.resize(LightScene::kStride - 1, 0);
      scene.tiles.insert(scene.tiles.end(), list.begin(), list.end());
    }
  scene.mean_list = double(listed) / (LightScene::kTiles * LightScene::kTiles);
  return scene;
}

// The probe's view of the scene (TERM_ADDITIONAL_LIGHTS) in double: Lambert + GGX, f0 0.04, roughness 0.5.
double reference_lights(const LightScene& scene, double x, double z) {
  const ref::Vec3 n{0, 1, 0};
  const ref::Vec3 v = ref::normalize({0, 1, 0.3});
  const double a = ref::PerceptualRoughnessToAlpha(0.5);
  double sum = 0;
  for (const auto& l : scene.lights) {
    ref::Vec3 to_light{l.x - x, l.y, l.z - z};
    double d2 = ref::dot(to_light, to_light);
    ref::Vec3 L = ref::normalize(to_light);
    ref::Vec3 h = ref::normalize(L + v);
    double NoL = std::clamp(ref::dot(n, L), 0.0, 1.0), NoV = std::max(ref::dot(n, v), 1e-4);
    double NoH = std::clamp(ref::dot(n, h), 0.0, 1.0), LoH = std::clamp(ref::dot(L, h), 0.0, 1.0);
    double F = ref::F_Schlick(0.04, 1.0, LoH);
    double brdf = 0.8 * ref::Fd_Lambert() * (1.0 - F) + ref::D_GGX(NoH, a) * ref::V_SmithGGXCorrelated(NoV, NoL, a) * F;
    sum += brdf * NoL * l.intensity * ref::DistanceAttenuation(d2, 1.0 / (LightScene::kRange * LightScene::kRange));
  }
  return sum;
}

struct Family {
  std::string name;
  std::string truth;
  std::string error_kind;  // "relative" or "absolute"
  std::vector<Point> points;
  std::vector<Member> members;
};

ProbeInput term_record(double r, double NoV, double NoL, double NoH, double LoH, double f0) {
  ProbeInput p{};
  p[0] = float(r), p[1] = float(NoV), p[2] = float(NoL), p[3] = float(NoH);
  p[4] = float(LoH), p[5] = float(f0);
  return p;
}

ProbeTexture table_texture(const ref::DfgTable& table, ProbeTexture::Format format) {
  ProbeTexture t;
  t.format = format;
  t.width = uint32_t(table.width);
  t.height = uint32_t(table.height);
  t.texels = table.rg;
  t.binding = 21;
  t.sampler_binding = 22;
  return t;
}

std::string format_name(ProbeTexture::Format f) {
  switch (f) {
    case ProbeTexture::Format::Rg32f: return "32-bit float";
    case ProbeTexture::Format::Rg16Unorm: return "16-bit unorm";
    case ProbeTexture::Format::Rg8Unorm: return "8-bit unorm";
  }
  return "";
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

// PerFrame (with _LightCounts at the offset the probe's reflection gives), _AdditionalLights, _TileLightIndices.
std::vector<ProbeBuffer> light_buffers(const kiln::gpu::ProbeProgram& program, const LightScene& scene) {
  const kiln::Reflection reflection = kiln::reflect_spirv(program.fragment);
  ProbeBuffer frame{0, true, {}};
  for (const kiln::Resource& r : reflection.resources) {
    if (r.name != "PerFrame") continue;
    frame.bytes.assign(r.size, 0);
    for (const kiln::BlockMember& m : r.members)
      if (m.name == "_LightCounts") {
        uint32_t counts[4] = {uint32_t(scene.lights.size()), LightScene::kTilePixels, LightScene::kTiles, 0};
        std::memcpy(frame.bytes.data() + m.offset, counts, sizeof counts);
      }
  }
  if (frame.bytes.empty()) {
    std::cerr << "kiln-shading-study: error: the Forward+ probe has no PerFrame block\n";
    return {};
  }
  ProbeBuffer lights{9, false, {}};
  for (const auto& l : scene.lights) {
    // AdditionalLight: positionWS (w: 1/range^2), color (w: no shadow), spotDirectionWS (w: 0 point), spotScaleOffset.
    float record[16] = {float(l.x), float(l.y), float(l.z), float(1.0 / (LightScene::kRange * LightScene::kRange)),
                        float(l.intensity), float(l.intensity), float(l.intensity), -1.0f,
                        0, -1, 0, 0, 0, 0, 0, 0};
    const auto* bytes = reinterpret_cast<const uint8_t*>(record);
    lights.bytes.insert(lights.bytes.end(), bytes, bytes + sizeof record);
  }
  ProbeBuffer tiles{10, false, {}};
  const auto* tile_bytes = reinterpret_cast<const uint8_t*>(scene.tiles.data());
  tiles.bytes.assign(tile_bytes, tile_bytes + scene.tiles.size() * sizeof(uint32_t));
  return {frame, lights, tiles};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: kiln-shading-study OUT.json\n";
    return 2;
  }
  auto opened = kiln::gpu::Lavapipe::open();
  if (!opened) {
    std::cerr << "kiln-shading-study: error: " << opened.error().message << "\n";
    return 1;
  }
  auto gpu = std::move(*opened);
  auto start = std::chrono::steady_clock::now();
  const auto roughness = linspace(0.045, 1.0, 24);
  const auto cosines = linspace(0.05, 1.0, 24);
  const auto light_cosines = linspace(0.1, 1.0, 8);
  std::vector<Family> families;

  // ---- Visibility: height-correlated Smith (exact) against its fast form and the separable form.
  {
    Family f{"Visibility (Smith GGX)", "exact height-correlated Smith GGX, double (Heitz 2014)", "relative", {}, {}};
    for (double r : roughness)
      for (double nov : cosines)
        for (double nol : light_cosines) {
          double a = ref::PerceptualRoughnessToAlpha(r);
          f.points.push_back({term_record(r, nov, nol, 1, 1, 0.04), ref::V_SmithGGXCorrelated(nov, nol, a), r >= 0.089});
        }
    f.members = {{"V_SmithGGXCorrelated fp32", {"TERM_V_CORRELATED"}, {}, "exact"},
                 {"V_SmithGGXCorrelated fp16", {"TERM_V_CORRELATED", "_HALF_PRECISION"}, {}, "exact, explicit fp16"},
                 {"V_SmithGGXCorrelated_Fast fp32", {"TERM_V_FAST"}, {}, "Hammon 2017, sqrt-free"},
                 {"V_SmithGGX_Separable fp32", {"TERM_V_SEPARABLE"}, {}, "uncorrelated Smith"}};
    families.push_back(f);
  }
  // ---- Distribution: D_GGX in fp32 and fp16.
  {
    Family f{"Distribution (GGX)", "D_GGX, double", "relative", {}, {}};
    for (double r : roughness)
      for (double noh : cosines) {
        double a = ref::PerceptualRoughnessToAlpha(r);
        f.points.push_back({term_record(r, 1, 1, noh, 1, 0.04), ref::D_GGX(noh, a), r >= 0.089});
      }
    f.members = {{"D_GGX fp32", {"TERM_D_GGX"}, {}, "exact"},
                 {"D_GGX fp16", {"TERM_D_GGX", "_HALF_PRECISION"}, {}, "exact, explicit fp16"}};
    families.push_back(f);
  }
  // ---- Fresnel: x^5 by multiplies against pow().
  {
    Family f{"Fresnel (Schlick)", "Schlick, double", "relative", {}, {}};
    for (double f0 : {0.04, 0.5, 1.0})
      for (double loh : linspace(0.0, 1.0, 192)) f.points.push_back({term_record(0.5, 1, 1, 1, loh, f0), ref::F_Schlick(f0, 1.0, loh)});
    f.members = {{"F_Schlick (multiply chain) fp32", {"TERM_F_SCHLICK"}, {}, "x^5 = x2 * x2 * x"},
                 {"F_Schlick (multiply chain) fp16", {"TERM_F_SCHLICK", "_HALF_PRECISION"}, {}, "explicit fp16"},
                 {"F_Schlick_Pow fp32", {"TERM_F_SCHLICK_POW"}, {}, "pow(x, 5)"}};
    families.push_back(f);
  }
  // ---- Diffuse: each model against its own double formula, and against Burley (model difference).
  for (auto [name, define, truth_fn] :
       std::vector<std::tuple<std::string, std::string, std::function<double(double, double, double, double)>>>{
           {"Fd_Lambert", "TERM_FD_LAMBERT", [](double, double, double, double) { return ref::Fd_Lambert(); }},
           {"Fd_Burley", "TERM_FD_BURLEY", ref::Fd_Burley},
           {"Fd_RenormalizedBurley", "TERM_FD_RENORMALIZED_BURLEY", ref::Fd_RenormalizedBurley}}) {
    Family f{"Diffuse: " + name, name + ", double", "relative", {}, {}};
    for (double r : roughness)
      for (double nov : cosines)
        for (double nol : light_cosines) {
          double loh = std::sqrt(0.5 * (1.0 + std::min(nov, nol)));  // a plausible LoH for the pair
          double rc = std::clamp(r, 0.045, 1.0);
          f.points.push_back({term_record(r, nov, nol, 1, loh, 0.04), truth_fn(nov, nol, loh, rc), r >= 0.089});
        }
    f.members = {{name + " fp32", {define}, {}, ""}, {name + " fp16", {define, "_HALF_PRECISION"}, {}, "explicit fp16"}};
    families.push_back(f);
  }

  // ---- Environment BRDF: DFG tables (16, 32, 64 texels; 8-, 16-bit, float) and EnvBRDFApprox against the
  // Monte-Carlo DFG integrals at each grid point. Error in the directional albedo E, absolute.
  std::cerr << "generating DFG tables and ground truth...\n";
  std::map<int, ref::DfgTable> tables;
  for (int size : {16, 32}) tables[size] = ref::make_dfg_table(size, size, 16384);
  {
    std::ifstream in(kRoot / "shaderlib/data/dfg64.kdfg", std::ios::binary);
    std::stringstream bytes;
    bytes << in.rdbuf();
    tables[64] = ref::decode_dfg_table(bytes.str());
  }
  const uint32_t truth_samples = 65536;
  std::map<std::pair<int, int>, std::array<double, 2>> dfg_truth;
  const auto env_rough = linspace(0.045, 1.0, 20);
  const auto env_nov = linspace(0.05, 1.0, 20);
  for (size_t i = 0; i < env_rough.size(); ++i)
    for (size_t j = 0; j < env_nov.size(); ++j) dfg_truth[{int(i), int(j)}] = ref::DFG(env_nov[j], env_rough[i], truth_samples);
  {
    Family f{"Environment BRDF (split-sum DFG)", "Monte-Carlo DFG integrals, 65536 samples per point", "absolute", {}, {}};
    for (double f0 : {0.04, 1.0})
      for (size_t i = 0; i < env_rough.size(); ++i)
        for (size_t j = 0; j < env_nov.size(); ++j) {
          auto dfg = dfg_truth[{int(i), int(j)}];
          f.points.push_back({term_record(env_rough[i], env_nov[j], 1, 1, 1, f0), dfg[0] + f0 * (dfg[1] - dfg[0]),
                              env_rough[i] >= 0.089});
        }
    for (int size : {16, 32, 64})
      for (auto format : {ProbeTexture::Format::Rg8Unorm, ProbeTexture::Format::Rg16Unorm, ProbeTexture::Format::Rg32f})
        f.members.push_back({"DFG table " + std::to_string(size) + "x" + std::to_string(size) + ", " + format_name(format),
                             {"TERM_ENV_TABLE", "PROBE_USES_TABLE", "PROBE_DFG_" + std::to_string(size)},
                             table_texture(tables[size], format), "bilinear"});
    f.members.push_back({"DFG table 64x64, 16-bit unorm, fp16 shader", {"TERM_ENV_TABLE", "PROBE_USES_TABLE", "_HALF_PRECISION"},
                         table_texture(tables[64], ProbeTexture::Format::Rg16Unorm), "explicit fp16"});
    f.members.push_back({"EnvBRDFApprox fp32", {"TERM_ENV_APPROX"}, {}, "Karis 2014 analytic fit"});
    f.members.push_back({"EnvBRDFApprox fp16", {"TERM_ENV_APPROX", "_HALF_PRECISION"}, {}, "explicit fp16"});
    families.push_back(f);
  }
  // ---- Multiscatter: white furnace, E(f0 = 1) * compensation, against 1. The single-scattering albedo
  // is the Monte-Carlo integral (independent of any table); the compensation comes from the GPU.
  {
    Family f{"Multiscatter (white furnace)", "energy 1 (white furnace): MC albedo x GPU compensation", "absolute", {}, {}};
    const auto furnace_nov = linspace(0.1, 1.0, 20);
    for (size_t i = 0; i < env_rough.size(); ++i)
      for (double nov : furnace_nov) {
        double albedo = ref::SpecularAlbedo(nov, ref::PerceptualRoughnessToAlpha(env_rough[i]), 1.0, truth_samples);
        f.points.push_back({term_record(env_rough[i], nov, 1, 1, 1, 1.0), 1.0, env_rough[i] >= 0.089, albedo});
      }
    for (int size : {16, 32, 64})
      f.members.push_back({"compensation, DFG table " + std::to_string(size) + "x" + std::to_string(size) + " float",
                           {"TERM_ENERGY_COMPENSATION", "PROBE_USES_TABLE", "PROBE_DFG_" + std::to_string(size)},
                           table_texture(tables[size], ProbeTexture::Format::Rg32f), "Kulla-Conty via 1/dfg.y"});
    f.members.push_back({"compensation, DFG table 64x64 16-bit unorm", {"TERM_ENERGY_COMPENSATION", "PROBE_USES_TABLE"},
                         table_texture(tables[64], ProbeTexture::Format::Rg16Unorm), ""});
    f.members.push_back({"no compensation (single scattering)", {"TERM_NONE"}, {}, "energy lost at high roughness"});
    families.push_back(f);
  }
  // ---- Light falloff: against the physical inverse-square law, inside the light's range (20 m).
  {
    Family f{"Light falloff (range 20 m)", "inverse-square law 1/d^2, double", "relative", {}, {}};
    for (double d : linspace(0.1, 19.0, 400)) {
      ProbeInput p{};
      p[6] = float(d * d), p[7] = float(1.0 / 400.0);
      f.points.push_back({p, 1.0 / (d * d)});
    }
    f.members = {{"windowed inverse square (Karis 2013; shaderlib default)", {"TERM_FALLOFF_WINDOWED"}, {}, ""},
                 {"UE4 literal 1/(d^2 + 1) with window (seed 002)", {"TERM_FALLOFF_UE4"}, {}, ""},
                 {"pure inverse square, no window", {"TERM_FALLOFF_INVERSE_SQUARE"}, {}, "infinite range"}};
    families.push_back(f);
  }
  // ---- Additional lights per vertex against per pixel: Lambert irradiance of a 1 cd point light over a
  // triangle of edge e, interpolated from the vertices or evaluated per pixel; truth per pixel in double.
  {
    Family f{"Additional lights: per vertex vs per pixel", "per-pixel Lambert irradiance / pi, double", "relative", {}, {}};
    for (double e : {0.25, 1.0})
      for (double height : {0.5, 1.0, 2.0, 4.0})
        for (double u : linspace(0.0, 1.0, 8))
          for (double v : linspace(0.0, 1.0, 8)) {
            if (u + v > 1.0) continue;
            ProbeInput p{};
            double lx = 0.3 * e, lz = 0.3 * e;
            p[8] = float(lx), p[9] = float(height), p[10] = float(lz);
            p[12] = float(u), p[13] = float(v), p[14] = float(e);
            double px = u * e, pz = v * e;
            ref::Vec3 to_light{lx - px, height, lz - pz};
            double d2 = ref::dot(to_light, to_light);
            double irradiance = ref::DistanceAttenuation(d2, 1.0 / 400.0) * (height / std::sqrt(d2)) / ref::kPi;
            f.points.push_back({p, irradiance});
          }
    f.members = {{"per pixel (_ADDITIONAL_LIGHTS)", {"TERM_LAMBERT_PER_PIXEL"}, {}, "one light per pixel"},
                 {"per vertex (_ADDITIONAL_LIGHTS_VERTEX)", {"TERM_LAMBERT_PER_VERTEX"}, {},
                  "fragment cost: applying the interpolated value; the light moves to the vertex stage",
                  {"TERM_APPLY_VERTEX_LIGHTING"}}};
    families.push_back(f);
  }

  // ---- Forward+ against the plain loop: the same lights, all of them per pixel or the tile's list.
  const LightScene light_scene = make_light_scene(128);
  {
    Family f{"Additional lights: Forward+ vs plain loop", "the same 128 lights summed in double", "relative", {}, {}};
    for (int py = 0; py < LightScene::kPixels; ++py)
      for (int px = 0; px < LightScene::kPixels; ++px) {
        ProbeInput p{};
        double x = (px + 0.5) * LightScene::kMetersPerPixel, z = (py + 0.5) * LightScene::kMetersPerPixel;
        p[0] = float(x), p[1] = float(z), p[4] = float(px + 0.5), p[5] = float(py + 0.5);
        f.points.push_back({p, reference_lights(light_scene, x, z)});
      }
    f.members = {{"plain loop (_ADDITIONAL_LIGHTS)", {"TERM_ADDITIONAL_LIGHTS"}, {}, "every light, every pixel", {},
                  double(light_scene.lights.size())},
                 {"Forward+ tiles (_ADDITIONAL_LIGHTS _FORWARD_PLUS)", {"TERM_ADDITIONAL_LIGHTS", "_FORWARD_PLUS"}, {},
                  "16x16-pixel tiles, conservative CPU lists", {}, light_scene.mean_list}};
    families.push_back(f);
  }

  // ---- Run everything.
  auto compile_term = [&](std::vector<std::string> defines) {
    defines.push_back("PROBE_TERM");
    auto program = kiln::gpu::compile_probe(kProbe, {kRoot / "shaderlib"}, defines);
    if (!program) {
      std::cerr << "kiln-shading-study: error: " << program.error().message << "\n";
      return std::optional<kiln::gpu::ProbeProgram>();
    }
    return std::optional<kiln::gpu::ProbeProgram>(std::move(*program));
  };
  auto baseline = compile_term({"TERM_NONE"});
  if (!baseline) return 1;
  double base_cost = kiln::gpu::weighted_cost(baseline->fragment).weighted;

  auto gpu_time = [&](const kiln::gpu::ProbeProgram& program, const std::optional<ProbeTexture>& texture,
                      const std::vector<ProbeBuffer>& buffers = {}, const std::vector<ProbeInput>& pattern = {}) {
    // 2^20 evaluations (one typical record, or `pattern` repeated), 9 runs: median and spread (max - min) / median.
    std::vector<ProbeInput> many(1u << 20, term_record(0.5, 0.5, 0.5, 0.9, 0.7, 0.04));
    for (size_t i = 0; !pattern.empty() && i < many.size(); ++i) many[i] = pattern[i % pattern.size()];
    std::vector<double> ms;
    for (int rep = 0; rep < 9; ++rep) {
      double t = 0;
      gpu->run(program, many, texture, &t, buffers);
      ms.push_back(t);
    }
    double m = median(ms);
    return std::make_pair(m, (*std::max_element(ms.begin(), ms.end()) - *std::min_element(ms.begin(), ms.end())) / m);
  };
  auto [base_ms, base_spread] = gpu_time(*baseline, std::nullopt);

  nlohmann::json out;
  out["device"] = gpu->device_name() + " (" + gpu->driver_info() + ")";
  std::time_t now = std::time(nullptr);
  char date[64];
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
  out["date"] = date;
  out["cost_weights"] = kiln::gpu::cost_weights_description();
  out["baseline"] = {{"weighted", base_cost}, {"gpu_ms", base_ms}, {"gpu_spread", base_spread}};
  for (const Family& family : families) {
    nlohmann::json fj;
    fj["name"] = family.name;
    fj["truth"] = family.truth;
    fj["error_kind"] = family.error_kind;
    fj["points"] = family.points.size();
    std::vector<ProbeInput> inputs;
    for (const Point& p : family.points) inputs.push_back(p.input);
    for (const Member& member : family.members) {
      std::cerr << family.name << ": " << member.name << "\n";
      auto program = compile_term(member.defines);
      if (!program) return 1;
      std::vector<ProbeBuffer> buffers;
      if (family.name.find("Forward+") != std::string::npos) {
        buffers = light_buffers(*program, light_scene);
        if (buffers.empty()) return 1;
      }
      auto values = gpu->run(*program, inputs, member.texture, nullptr, buffers);
      bool fp16 = program->float16;
      bool furnace = family.name.rfind("Multiscatter", 0) == 0;
      std::vector<double> errors;
      for (size_t i = 0; i < values.size(); ++i) {
        const Point& p = family.points[i];
        if (fp16 && !p.fp16_domain) continue;
        double got = values[i][0];
        double truth = p.truth;
        if (furnace) {
          // E(f0 = 1) by Monte Carlo times the GPU's compensation factor (1 without compensation).
          got = member.defines[0] == "TERM_NONE" ? p.albedo : p.albedo * got;
        }
        double e = std::abs(got - truth);
        if (family.error_kind == "relative") e /= std::max(std::abs(truth), 1e-12);
        errors.push_back(e);
      }
      double sum = 0;
      for (double e : errors) sum += e;
      kiln::gpu::ShaderCost cost = kiln::gpu::weighted_cost(program->fragment);
      if (!member.cost_defines.empty()) {
        auto cost_program = compile_term(member.cost_defines);
        if (!cost_program) return 1;
        cost = kiln::gpu::weighted_cost(cost_program->fragment);
      }
      // The Forward+ family is timed on its own frame (every tile), the others on one typical record.
      auto [ms, spread] = gpu_time(*program, member.texture, buffers, buffers.empty() ? std::vector<ProbeInput>{} : inputs);
      nlohmann::json mj;
      mj["name"] = member.name;
      mj["note"] = member.note;
      mj["fp16"] = fp16;
      mj["points"] = errors.size();
      mj["max_error"] = errors.empty() ? 0.0 : *std::max_element(errors.begin(), errors.end());
      mj["mean_error"] = errors.empty() ? 0.0 : sum / double(errors.size());
      mj["cost"] = cost.weighted - base_cost;
      mj["texture_fetches"] = cost.texture_fetches;
      mj["gpu_ms"] = ms - base_ms;
      mj["gpu_spread"] = spread;
      if (member.lights_per_pixel > 0) mj["lights_per_pixel"] = member.lights_per_pixel;
      fj["members"].push_back(mj);
    }
    out["families"].push_back(fj);
  }
  out["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::ofstream(argv[1]) << out.dump(2) << "\n";
  std::cerr << "wrote " << argv[1] << "\n";
  return 0;
}
