// SPDX-License-Identifier: Apache-2.0
// The accuracy gate (ctest label `stress`, next to the NaN/Inf gate): shaderlib's BRDF terms, light functions,
// IBL helpers and the direct lighting of a light, compiled by kiln's front end and run on lavapipe over dense
// grids of their valid domain, each compared with the double-precision CPU reference (verify/reference) under a
// stated bound, in fp32 and in explicit fp16. Plus the two energy checks of issue 23:
// - the direct specular lobe of the fp16 path keeps the energy of the fp32 path down to grazing angles;
// - the DFG table, looked up as the shaders look it up, against an integrator that is not the table's generator.
// Results go to a JSON report for bench/REPORT.md (KILN_ACCURACY_REPORT overrides the path).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "common/parallel.hpp"
#include "lavapipe_suite.hpp"
#include "probe/lavapipe.hpp"
#include "reference/reference.hpp"

namespace kiln::gpu {
namespace {

namespace ref = kiln::reference;

const std::filesystem::path kShaderlib = std::filesystem::path(KILN_SOURCE_DIR) / "shaderlib";
const std::filesystem::path kProbe = std::filesystem::path(KILN_SOURCE_DIR) / "tests/gpu/Probe.hlsl";
const std::filesystem::path kDfgTable = kShaderlib / "data/dfg64.kdfg";

// The roughness floors of shaderlib/Common.hlsl: each precision is compared on its own valid domain.
constexpr double kMinRoughnessFp32 = 0.045;
constexpr double kMinRoughnessFp16 = 0.089;

ref::DfgTable shipped_dfg_table() {
  std::ifstream in(kDfgTable, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  return ref::decode_dfg_table(bytes.str());
}

ProbeTexture table_texture(const ref::DfgTable& table) {
  ProbeTexture t;
  t.format = ProbeTexture::Format::Rg32f;  // as the renderers upload it (R32G32_SFLOAT)
  t.width = uint32_t(table.width);
  t.height = uint32_t(table.height);
  t.texels = table.rg;
  t.binding = 21;
  t.sampler_binding = 22;
  return t;
}

std::vector<double> log_spaced(double from, double to, int count) {
  std::vector<double> v;
  for (int i = 0; i < count; ++i) v.push_back(from * std::pow(to / from, double(i) / (count - 1)));
  return v;
}

class Accuracy : public LavapipeSuite<Accuracy> {
 public:
  static constexpr const char* kReportEnvironment = "KILN_ACCURACY_REPORT";  // bench/run_all.sh points it into bench/results/
  static constexpr const char* kReportPath = KILN_ACCURACY_REPORT_PATH;

 protected:
  std::vector<ProbeOutput> run(std::vector<std::string> defines, const std::vector<ProbeInput>& inputs,
                               const std::optional<ProbeTexture>& texture = std::nullopt) {
    auto program = compile_probe(kProbe, {kShaderlib}, defines);
    EXPECT_TRUE(program) << program.error().message;
    if (!program) return {};
    auto out = gpu_->run(*program, inputs, texture);
    EXPECT_EQ(out.size(), inputs.size());
    return out;
  }

};


//------------------------------------------------------------------------------------------------------------
// Issue 23, item 7: every public term against the double reference, on a dense grid of its valid domain.
//------------------------------------------------------------------------------------------------------------

// Error of a GPU value against the double reference: relative, with magnitudes below `floor` counted as
// `floor` (an absolute error there: values that are ~0 in both must not give meaningless ratios).
double relative_error(double gpu, double expected, double floor) {
  return std::abs(gpu - expected) / std::max(std::abs(expected), floor);
}

// One output of a probe: its reference, and the bound in each precision with the reason for it.
struct TermCheck {
  const char* name;
  std::function<double(const ProbeInput&, double min_roughness)> reference;
  double bound_fp32;
  double bound_fp16;
  double floor = 1e-3;
};

struct TermProbe {
  const char* probe;                  // PROBE_* define
  bool roughness_in_a_x;              // a.x is the perceptual roughness (fp16 is compared from its floor)
  std::vector<std::string> defines;   // extra defines (keywords)
  std::array<TermCheck, 4> outputs;   // x, y, z, w
};

// The inputs as the probe decodes them (tests/gpu/Probe.hlsl, DecodeTerms), in double from the float record.
struct Terms {
  double perceptual_roughness, alpha, NoV, NoL, NoH, LoH, f0;
};
Terms decode(const ProbeInput& p, double min_roughness) {
  Terms t{};
  t.perceptual_roughness = std::clamp(double(p[0]), min_roughness, 1.0);
  t.alpha = t.perceptual_roughness * t.perceptual_roughness;
  t.NoV = std::max(double(p[1]), 1e-4);
  t.NoL = std::clamp(double(p[2]), 0.0, 1.0);
  t.NoH = std::clamp(double(p[3]), 0.0, 1.0);
  t.LoH = std::clamp(double(p[4]), 0.0, 1.0);
  t.f0 = p[5];
  return t;
}

// The anisotropic alphas as PrepareShading forms them.
std::array<double, 2> anisotropic_alphas(const ProbeInput& p, double min_roughness) {
  Terms t = decode(p, min_roughness);
  double anisotropy = std::clamp(double(p[6]), -1.0, 1.0);
  return {std::max(t.alpha * (1 + anisotropy), min_roughness * min_roughness),
          std::max(t.alpha * (1 - anisotropy), min_roughness * min_roughness)};
}

// (sin(theta) cos(phi), sin(theta) sin(phi)) of a direction with cos(theta) = cosine, computed in fp32 as the
// probe computes it (tests/gpu/Probe.hlsl, PROBE_SPECULAR_MORE).
std::array<double, 2> probe_frame(float cosine, float phi) {
  float sine = std::sqrt(std::max(1.0f - cosine * cosine, 0.0f));
  return {double(sine * std::cos(phi)), double(sine * std::sin(phi))};
}

// The valid domain, densely: roughness from 0.045 (fp32's floor; fp16 compares from 0.089), NoV and NoL from
// 1e-3 (grazing) to 1, NoH up to 1 - 1e-4, LoH over [0, 1], three f0, anisotropy and tangent rotations cycled.
std::vector<ProbeInput> term_domain_grid() {
  const std::vector<double> roughness = {0.045, 0.06, 0.089, 0.1, 0.125, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.6, 0.75, 0.9, 1.0};
  const std::vector<double> cosine = {1e-3, 2e-3, 5e-3, 0.01, 0.03, 0.1, 0.2, 0.35, 0.5, 0.7, 0.85, 0.95, 1.0};
  const std::vector<double> noh = {0.0, 0.2, 0.5, 0.7, 0.9, 0.95, 0.98, 0.99, 0.995, 0.999, 0.9999, 1.0};
  const std::vector<double> f0 = {0.04, 0.5, 1.0};
  const std::vector<double> loh = {0.0, 0.05, 0.2, 0.5, 0.8, 1.0};
  const std::vector<double> anisotropy = {-0.8, -0.3, 0.0, 0.4, 0.9};
  const std::vector<double> dfg = {0.05, 0.3, 0.6, 0.95};
  const std::vector<double> tone = {0.0, 1e-3, 0.05, 0.18, 1.0, 4.0, 30.0, 1e3};
  std::vector<ProbeInput> grid;
  size_t i = 0;
  for (double r : roughness)
    for (double v : cosine)
      for (double l : cosine)
        for (double h : noh) {
          ProbeInput p{};
          p[0] = float(r), p[1] = float(v), p[2] = float(l), p[3] = float(h);
          p[4] = float(loh[i % loh.size()]), p[5] = float(f0[(i / 7) % f0.size()]);
          p[6] = float(anisotropy[i % anisotropy.size()]), p[7] = float(0.3 * double(i % 11));
          double y = dfg[i % dfg.size()];
          p[8] = float(y * (0.3 + 0.5 * double((i / 4) % 2))), p[9] = float(y);
          double t = tone[i % tone.size()];
          p[12] = float(t), p[13] = float(t * 0.5), p[14] = float(t * 0.25);
          grid.push_back(p);
          ++i;
        }
  return grid;
}

// c = (distance^2, 1/range^2, cos inner, cos outer), d = (cos to the spot axis, kelvin, lumens, -), in range.
std::vector<ProbeInput> light_domain_grid() {
  std::vector<ProbeInput> grid;
  const std::vector<double> distance2 = log_spaced(1e-3, 1e4, 15);
  const std::vector<double> range = {0.5, 2.0, 10.0, 100.0};
  const std::vector<std::pair<double, double>> cones = {{0.95, 0.9}, {0.99, 0.7}, {0.5, 0.2}, {0.9, 0.9}};
  const std::vector<double> cos_theta = {-0.5, 0.2, 0.6, 0.8, 0.9, 0.93, 0.97, 1.0};
  const std::vector<double> kelvin = log_spaced(1000, 40000, 9);
  size_t i = 0;
  for (double d2 : distance2)
    for (double r : range)
      for (auto [inner, outer] : cones)
        for (double c : cos_theta) {
          ProbeInput p{};
          p[8] = float(d2), p[9] = float(1 / (r * r)), p[10] = float(inner), p[11] = float(outer);
          p[12] = float(c), p[13] = float(kelvin[i % kelvin.size()]), p[14] = float(1e3 * double(i % 5 + 1));
          p[15] = float(0.089 + 0.911 * double(i % 13) / 12.0);  // perceptual roughness (fp16's floor up)
          grid.push_back(p);
          ++i;
        }
  return grid;
}

// fp32 bounds: the terms are exact formulas; the GPU's error is a few fp32 ulps times the formula's condition
// (sqrt, exp2 and division on llvmpipe are correctly rounded or within 1-2 ulp); 1e-5 leaves 10x over the
// measured maxima (bench/REPORT.md). fp16 bounds: the inputs alone are rounded to 11 bits (4.9e-4 relative)
// and D, V and Burley raise them to powers (D near its peak ~ 1/alpha^2 ~ 1/r^4: 4 x 4.9e-4 from r alone),
// so 1e-2 for the powered terms, 5e-3 for the others; the measured maxima are in the report.
const std::vector<TermProbe>& term_probes() {
  static const std::vector<TermProbe> probes = {
      {"PROBE_SPECULAR",
       true,
       {},
       {TermCheck{"D_GGX", [](const ProbeInput& p, double m) { Terms t = decode(p, m); return ref::D_GGX(t.NoH, t.alpha); }, 1e-5, 1e-2},
        TermCheck{"V_SmithGGXCorrelated",
                  [](const ProbeInput& p, double m) { Terms t = decode(p, m); return ref::V_SmithGGXCorrelated(t.NoV, t.NoL, t.alpha); },
                  1e-5, 1e-2},
        TermCheck{"V_SmithGGXCorrelated_Fast",
                  [](const ProbeInput& p, double m) { Terms t = decode(p, m); return ref::V_SmithGGXCorrelated_Fast(t.NoV, t.NoL, t.alpha); },
                  1e-5, 1e-2},
        TermCheck{"F_Schlick", [](const ProbeInput& p, double m) { Terms t = decode(p, m); return ref::F_Schlick(t.f0, 1.0, t.LoH); },
                  1e-5, 5e-3}}},
      {"PROBE_SPECULAR_MORE",
       true,
       {},
       {TermCheck{"V_SmithGGX_Separable",
                  [](const ProbeInput& p, double m) { Terms t = decode(p, m); return ref::V_SmithGGX_Separable(t.NoV, t.NoL, t.alpha); },
                  1e-5, 1e-2},
        TermCheck{"F_Schlick_Pow", [](const ProbeInput& p, double m) { Terms t = decode(p, m); return ref::F_Schlick(t.f0, 1.0, t.LoH); },
                  1e-5, 5e-3},
        TermCheck{"D_GGX_Anisotropic",
                  [](const ProbeInput& p, double m) {
                    auto [at, ab] = anisotropic_alphas(p, m);
                    double NoH = std::clamp(double(p[3]), 0.0, 1.0);
                    // The probe derives the tangent-frame cosines in fp32; near NoH = 1 that rounding (not the
                    // library's) moves this narrow lobe by 1e-4, so the reference starts from the same floats.
                    auto frame = probe_frame(p[3], p[7]);
                    return ref::D_GGX_Anisotropic(NoH, frame[0], frame[1], at, ab);
                  },
                  1e-5, 1e-2},
        TermCheck{"V_SmithGGXCorrelated_Anisotropic",
                  [](const ProbeInput& p, double m) {
                    auto [at, ab] = anisotropic_alphas(p, m);
                    auto view = probe_frame(p[1], 0.0f);
                    auto light = probe_frame(p[2], p[7]);
                    return ref::V_SmithGGXCorrelated_Anisotropic(at, ab, view[0], 0.0, light[0], light[1],
                                                                 std::max(double(p[1]), 1e-4), std::clamp(double(p[2]), 0.0, 1.0));
                  },
                  1e-5, 1e-2}}},
      {"PROBE_DIFFUSE",
       true,
       {},
       {TermCheck{"Fd_Lambert", [](const ProbeInput&, double) { return ref::Fd_Lambert(); }, 1e-5, 5e-3},
        TermCheck{"Fd_Burley",
                  [](const ProbeInput& p, double m) { Terms t = decode(p, m); return ref::Fd_Burley(t.NoV, t.NoL, t.LoH, t.perceptual_roughness); },
                  1e-5, 1e-2},
        // fp16: at grazing NoV and NoL with LoH ~ 0, each Schlick factor 1 + (fd90 - 1) (1 - NoX)^5 cancels to
        // ~0.09 (fd90 = 0.045 at roughness 0.089), losing 3-4 of fp16's 11 bits in each: measured 2.5e-2.
        TermCheck{"Fd_RenormalizedBurley",
                  [](const ProbeInput& p, double m) {
                    Terms t = decode(p, m);
                    return ref::Fd_RenormalizedBurley(t.NoV, t.NoL, t.LoH, t.perceptual_roughness);
                  },
                  1e-5, 5e-2},
        TermCheck{"V_Kelemen_UnityMobile",
                  [](const ProbeInput& p, double m) { Terms t = decode(p, m); return ref::V_Kelemen_UnityMobile(t.LoH, t.perceptual_roughness); },
                  1e-5, 5e-3}}},
      {"PROBE_IBL",
       true,
       {},
       {TermCheck{"EnvBRDFApprox",
                  [](const ProbeInput& p, double m) {
                    Terms t = decode(p, m);
                    auto ab = ref::EnvBRDFApprox(t.perceptual_roughness, t.NoV);
                    return std::clamp(t.f0 * ab[0] + ab[1], 0.0, 1.0);
                  },
                  1e-5, 1e-2},
        TermCheck{"EnergyCompensation",
                  [](const ProbeInput& p, double) { return ref::EnergyCompensation(std::max(double(p[9]), 1e-3), p[5]); }, 1e-5, 5e-3},
        TermCheck{"SpecularDFG", [](const ProbeInput& p, double) { return double(p[8]) + (double(p[9]) - p[8]) * p[5]; }, 1e-5, 5e-3},
        TermCheck{"ACESFitted.g", [](const ProbeInput& p, double) { return ref::ACESFitted({p[12], p[13], p[14]})[1]; }, 1e-5, 1e-5}}},
  };
  return probes;
}

const TermProbe& light_probe() {
  static const TermProbe probe = {
      "PROBE_LIGHTS",
      false,
      {},
      {TermCheck{"DistanceAttenuation", [](const ProbeInput& p, double) { return ref::DistanceAttenuation(p[8], p[9]); }, 1e-5, 1e-5, 1e-6},
       TermCheck{"SpotAttenuation", [](const ProbeInput& p, double) { return ref::SpotAttenuation(p[12], p[10], p[11]); }, 1e-5, 1e-5},
       TermCheck{"SpotLightLumensToCandela", [](const ProbeInput& p, double) { return ref::SpotLightLumensToCandela(p[14], p[11]); },
                 1e-5, 1e-5},
       TermCheck{"ColorTemperatureToLinearRGB (r + g + b)",
                 [](const ProbeInput& p, double) {
                   auto c = ref::ColorTemperatureToLinearRGB(p[13]);
                   return c[0] + c[1] + c[2];
                 },
                 1e-5, 1e-5}}};
  return probe;
}

const TermProbe& more_lights_probe() {
  static const TermProbe probe = {
      "PROBE_LIGHTS_MORE",
      false,
      {},
      {TermCheck{"PointLightLumensToCandela", [](const ProbeInput& p, double) { return ref::PointLightLumensToCandela(p[14]); }, 1e-5, 1e-5},
       TermCheck{"DistanceAttenuation_UE4", [](const ProbeInput& p, double) { return ref::DistanceAttenuation_UE4(p[8], p[9]); }, 1e-5, 1e-5},
       TermCheck{"DistanceAttenuation_InverseSquare",
                 [](const ProbeInput& p, double) { return ref::DistanceAttenuation_InverseSquare(p[8]); }, 1e-5, 1e-5},
       // fp16: 2 / r^4 amplifies the input's rounding 4x (4.9e-4 each).
       TermCheck{"RoughnessToSpecularPower", [](const ProbeInput& p, double) { return ref::RoughnessToSpecularPower(p[15]); }, 1e-5, 1e-2}}};
  return probe;
}

// SampleSH9: coefficient k = (s_k, s_k / 2, -s_k) from the record (tests/gpu/Probe.hlsl, PROBE_SH9).
double sh9_reference(const ProbeInput& p, double scale) {
  std::array<double, 9> sh{};
  for (int k = 0; k < 9; ++k) sh[k] = scale * double(p[4 + k]);
  return ref::SampleSH9(sh, {p[0], p[1], p[2]});
}

const TermProbe& sh9_probe() {
  static const TermProbe probe = {
      "PROBE_SH9",
      false,
      {},
      // Floor 1e-2: the sum cancels 9 terms of order 1, so near 0 its error is absolute, a few fp32 ulps of 1
      // (measured 8.6e-8, 8.6e-6 against the floor); 5e-5 leaves room for a different summation order. fp32 in
      // every variant (the coefficients are float).
      {TermCheck{"SampleSH9 (r)", [](const ProbeInput& p, double) { return sh9_reference(p, 1.0); }, 5e-5, 5e-5, 1e-2},
       TermCheck{"SampleSH9 (g, coefficients halved)", [](const ProbeInput& p, double) { return sh9_reference(p, 0.5); }, 5e-5, 5e-5, 1e-2},
       TermCheck{"SampleSH9 (b, coefficients negated)", [](const ProbeInput& p, double) { return sh9_reference(p, -1.0); }, 5e-5, 5e-5, 1e-2},
       TermCheck{"-", [](const ProbeInput&, double) { return 0.0; }, 0.0, 0.0}}};
  return probe;
}

// Unit normals over the sphere (a Fibonacci lattice) and SH coefficients of mixed signs and magnitudes.
std::vector<ProbeInput> sh9_grid() {
  std::vector<ProbeInput> grid;
  for (int i = 0; i < 2048; ++i) {
    double z = 1.0 - (i + 0.5) / 1024.0, r = std::sqrt(std::max(0.0, 1.0 - z * z)), phi = 2.399963229728653 * i;
    ProbeInput p{};
    p[0] = float(r * std::cos(phi)), p[1] = float(r * std::sin(phi)), p[2] = float(z);
    for (int k = 0; k < 9; ++k) p[4 + k] = float(std::sin(1.7 * k + 0.37 * i) * (k == 0 ? 2.0 : 1.0 / (1 + k % 4)));
    grid.push_back(p);
  }
  return grid;
}

struct TermResult {
  double max_error = 0, mean_error = 0;
  size_t points = 0;
  std::string worst;
};

TermResult compare(const TermCheck& check, int output, const std::vector<ProbeInput>& grid,
                   const std::vector<ProbeOutput>& out, bool roughness_in_a_x, double min_roughness) {
  TermResult result;
  double sum = 0;
  for (size_t i = 0; i < grid.size(); ++i) {
    // Below this precision's roughness floor the lobe is clamped to another one by design.
    if (roughness_in_a_x && double(grid[i][0]) < min_roughness - 1e-6) continue;
    double expected = check.reference(grid[i], min_roughness);
    double error = relative_error(out[i][output], expected, check.floor);
    ++result.points;
    sum += error;
    if (error > result.max_error) {
      result.max_error = error;
      std::ostringstream where;
      where << "record (" << grid[i][0] << ", " << grid[i][1] << ", " << grid[i][2] << ", " << grid[i][3] << " | "
            << grid[i][4] << ", " << grid[i][5] << ", " << grid[i][6] << ", " << grid[i][7] << " | " << grid[i][8]
            << ", " << grid[i][9] << ", " << grid[i][10] << ", " << grid[i][11] << " | " << grid[i][12] << ", "
            << grid[i][13] << ", " << grid[i][14] << "): GPU " << out[i][output] << ", double " << expected;
      result.worst = where.str();
    }
  }
  result.mean_error = result.points ? sum / double(result.points) : 0;
  return result;
}

void gate_terms(const TermProbe& probe, const std::vector<ProbeInput>& grid,
                const std::function<std::vector<ProbeOutput>(std::vector<std::string>, const std::vector<ProbeInput>&)>& run,
                nlohmann::json& report) {
  for (bool half : {false, true}) {
    std::vector<std::string> defines = probe.defines;
    defines.push_back(probe.probe);
    if (half) defines.push_back("_HALF_PRECISION");
    auto out = run(defines, grid);
    ASSERT_EQ(out.size(), grid.size());
    const double min_roughness = half ? kMinRoughnessFp16 : kMinRoughnessFp32;
    for (int k = 0; k < 4; ++k) {
      const TermCheck& check = probe.outputs[k];
      if (std::string(check.name) == "-") continue;  // an unused output
      TermResult r = compare(check, k, grid, out, probe.roughness_in_a_x, min_roughness);
      double bound = half ? check.bound_fp16 : check.bound_fp32;
      EXPECT_LE(r.max_error, bound) << check.name << (half ? " fp16" : " fp32") << " over " << r.points
                                    << " points; worst at " << r.worst;
      report.push_back({{"term", check.name}, {"probe", probe.probe}, {"precision", half ? "fp16" : "fp32"},
                        {"points", r.points}, {"max", r.max_error}, {"mean", r.mean_error}, {"bound", bound},
                        {"worst", r.worst}});
    }
  }
}

TEST_F(Accuracy, BrdfAndIblTermsMatchTheDoubleReferenceOnTheirDomainInFp32AndFp16) {
  auto grid = term_domain_grid();
  ASSERT_GE(grid.size(), 30000u);
  for (const TermProbe& probe : term_probes())
    gate_terms(probe, grid, [&](auto defines, const auto& g) { return run(defines, g); }, report_["terms"]);
}

TEST_F(Accuracy, LightFunctionsMatchTheDoubleReferenceInFp32AndFp16) {
  auto grid = light_domain_grid();
  gate_terms(light_probe(), grid, [&](auto defines, const auto& g) { return run(defines, g); }, report_["terms"]);
  gate_terms(more_lights_probe(), grid, [&](auto defines, const auto& g) { return run(defines, g); }, report_["terms"]);
}

// Fog (shaderlib/Fog.hlsl), one probe per multi_compile_fog mode (tests/gpu/Probe.hlsl, PROBE_FOG). The fog is
// evaluated in float in every variant, so fp16 variants are held to the fp32 bounds. Bounds: exp2 and the division
// on llvmpipe are within a few fp32 ulps; 1e-5 leaves room over the measured maxima (bench/REPORT.md, "Accuracy gate").
TermProbe fog_probe(const char* mode, std::function<double(const ProbeInput&)> factor) {
  return {"PROBE_FOG",
          false,
          {mode},
          {TermCheck{"ComputeFogFactor", [factor](const ProbeInput& p, double) { return factor(p); }, 1e-5, 1e-5},
           TermCheck{"MixFog", [factor](const ProbeInput& p, double) { return ref::MixFog(p[12], p[13], factor(p)); }, 1e-5, 1e-5},
           // The depth of a point c.x in front of the camera, from a camera moved back by d.z: c.x + d.z, exactly.
           // Floor 0.1 m: near the camera the error is absolute, the rounding of world positions of magnitude ~3.
           TermCheck{"ComputeFogDepth", [](const ProbeInput& p, double) { return double(p[8]) + double(p[14]); }, 1e-5, 1e-5, 0.1},
           TermCheck{"-", [](const ProbeInput&, double) { return 0.0; }, 0.0, 0.0}}};
}

// View depths from 0 to 2 km; densities from none to opaque; linear planes ordinary, far apart and equal.
std::vector<ProbeInput> fog_domain_grid() {
  std::vector<ProbeInput> grid;
  std::vector<double> depths = log_spaced(1e-3, 2e3, 40);
  depths.push_back(0);
  const std::vector<double> densities = {0, 1e-3, 0.035, 0.2, 1, 5};
  const std::vector<std::pair<double, double>> planes = {{0, 10}, {3, 22}, {5, 5}, {10, 1000}};
  const std::vector<double> offsets = {0, 0.5, 7};
  size_t i = 0;
  for (double d : depths)
    for (double density : densities)
      for (auto [start, end] : planes) {
        ProbeInput p{};
        p[8] = float(d), p[9] = float(density), p[10] = float(start), p[11] = float(end);
        p[12] = float(0.05 + 3.0 * double(i % 7) / 6.0), p[13] = float(0.2 + 0.6 * double(i % 5) / 4.0);
        p[14] = float(offsets[i % offsets.size()]);
        grid.push_back(p);
        ++i;
      }
  return grid;
}

TEST_F(Accuracy, FogFunctionsMatchTheDoubleReferenceInEveryFogMode) {
  auto grid = fog_domain_grid();
  ASSERT_GE(grid.size(), 900u);
  gate_terms(fog_probe("FOG_LINEAR", [](const ProbeInput& p) { return ref::FogFactorLinear(p[8], p[10], p[11]); }), grid,
             [&](auto defines, const auto& g) { return run(defines, g); }, report_["terms"]);
  gate_terms(fog_probe("FOG_EXP", [](const ProbeInput& p) { return ref::FogFactorExp(p[8], p[9]); }), grid,
             [&](auto defines, const auto& g) { return run(defines, g); }, report_["terms"]);
  gate_terms(fog_probe("FOG_EXP2", [](const ProbeInput& p) { return ref::FogFactorExp2(p[8], p[9]); }), grid,
             [&](auto defines, const auto& g) { return run(defines, g); }, report_["terms"]);
}

TEST_F(Accuracy, SphericalHarmonicsIrradianceMatchesTheDoubleReferenceInFp32AndFp16) {
  gate_terms(sh9_probe(), sh9_grid(), [&](auto defines, const auto& g) { return run(defines, g); }, report_["terms"]);
}

//------------------------------------------------------------------------------------------------------------
// Issue 23, item 1: the energy of the direct specular lobe in fp16.
//------------------------------------------------------------------------------------------------------------

// Directional albedo of DirectBRDF's output, E(NoV) = ∫ DirectBRDF(L) dω_L, estimated with the same GGX-sampled
// L directions for fp32 and fp16 (so the estimates differ only by what the GPU computed), Hammersley points,
// the pdf in double. Every L with NoL > 0 counts (the domain NoL >= 1e-3 plus the thin rest below it).
struct DirectCell {
  double roughness, NoV;
  std::vector<double> inverse_pdf;  // one per record; 0 where L falls below the horizon (not drawn)
  std::vector<double> reference;    // double DirectBRDF of the white metal at the record, f0 = 1
};

TEST_F(Accuracy, Fp16DirectSpecularLobeKeepsTheEnergyOfFp32DownToGrazingAngles) {
  const std::vector<double> roughness = {0.089, 0.1, 0.125, 0.2, 0.35, 0.6, 1.0};
  const std::vector<double> nov = {1e-3, 2e-3, 3e-3, 5e-3, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0};
  const uint32_t samples = 2048;
  std::vector<ProbeInput> records;
  std::vector<DirectCell> cells;
  for (double r : roughness)
    for (double v : nov) {
      // The GPU sees float inputs: the CPU side works from the same rounded values.
      const double rf = double(float(r)), vf = double(float(v));
      const double alpha = rf * rf;
      // The energy compensation's dfg.y: the true albedo (any fixed value would do: fp32 and fp16 both read it).
      const double E = ref::DFGQuadrature(vf, alpha, 512, 64)[1];
      DirectCell cell{r, v, {}, {}};
      // V as the probe receives it (c.xyz): the GPU and the reference start from the same floats, which matters
      // at grazing angles where L + V nearly cancels.
      const float sinV = float(std::sqrt(1 - vf * vf));
      const ref::Vec3 V{double(sinV), 0, vf};
      for (uint32_t i = 0; i < samples; ++i) {
        auto u = ref::hammersley(i, samples);
        double phi = 2 * ref::kPi * u[0];
        double cosTheta = std::sqrt((1 - u[1]) / (1 + (alpha * alpha - 1) * u[1]));
        double sinTheta = std::sqrt(std::max(0.0, 1 - cosTheta * cosTheta));
        ref::Vec3 H{sinTheta * std::cos(phi), sinTheta * std::sin(phi), cosTheta};
        double VoH = ref::dot(V, H);
        ref::Vec3 L = H * (2 * VoH) - V;
        ProbeInput p{};
        p[0] = float(r), p[1] = float(v), p[2] = float(E), p[3] = float(E);
        p[4] = float(L.x), p[5] = float(L.y), p[6] = float(L.z);
        p[8] = sinV, p[10] = float(vf);
        records.push_back(p);
        if (L.z <= 0 || VoH <= 0) {
          cell.inverse_pdf.push_back(0);
          cell.reference.push_back(0);
          continue;
        }
        // pdf(L) = D(h) NoH / (4 VoH)
        cell.inverse_pdf.push_back(4 * VoH / (ref::D_GGX(H.z, alpha) * H.z));
        // The reference at the float L the GPU got.
        ref::Vec3 Lf{p[4], p[5], p[6]};
        ref::Vec3 Hf = ref::normalize(Lf + V);
        double NoL = std::clamp(Lf.z, 0.0, 1.0);
        double F = ref::F_Schlick(1.0, 1.0, std::clamp(ref::dot(Lf, Hf), 0.0, 1.0));
        cell.reference.push_back(ref::D_GGX(Hf.z, alpha) * ref::V_SmithGGXCorrelated(vf, NoL, alpha) * F *
                                 ref::EnergyCompensation(double(float(E)), 1.0) * NoL);
      }
      cells.push_back(std::move(cell));
    }

  nlohmann::json entry;
  for (const std::vector<std::string>& keywords : {std::vector<std::string>{"_MULTISCATTER"}, std::vector<std::string>{}}) {
    std::vector<std::string> defines = keywords;
    defines.push_back("PROBE_DIRECT");
    auto full = run(defines, records);
    defines.push_back("_HALF_PRECISION");
    auto half = run(defines, records);
    ASSERT_EQ(full.size(), records.size());
    ASSERT_EQ(half.size(), records.size());
    std::string name = keywords.empty() ? "(none)" : keywords[0];
    double worst16 = 0, worst32 = 0, worst_accumulate = 0;
    // Pointwise, DirectBRDF of the white metal against the double reference at every sampled L above the
    // horizon: fp32 within 1e-5 (measured 1e-6 down to NoV = 1e-3, the V the GPU gets being the reference's),
    // fp16 within 1e-2 (D and V are fp16 terms; measured 6e-3).
    std::array<TermResult, 2> pointwise{};
    for (size_t c = 0; c < cells.size(); ++c)
      for (uint32_t i = 0; i < samples; ++i) {
        if (cells[c].inverse_pdf[i] == 0) continue;
        const size_t k = c * samples + i;
        for (int h = 0; h < 2; ++h) {
          double error = relative_error((h ? half : full)[k][0], cells[c].reference[i], 1e-3);
          ++pointwise[h].points;
          if (error > pointwise[h].max_error) {
            pointwise[h].max_error = error;
            pointwise[h].worst = "roughness " + std::to_string(cells[c].roughness) + " NoV " + std::to_string(cells[c].NoV) +
                                 " L (" + std::to_string(records[k][4]) + ", " + std::to_string(records[k][5]) + ", " +
                                 std::to_string(records[k][6]) + "): GPU " + std::to_string((h ? half : full)[k][0]) +
                                 ", double " + std::to_string(cells[c].reference[i]);
          }
        }
      }
    if (name == "_MULTISCATTER") {
      EXPECT_LE(pointwise[0].max_error, 1e-5) << "DirectBRDF fp32 pointwise, worst at " << pointwise[0].worst;
      EXPECT_LE(pointwise[1].max_error, 1e-2) << "DirectBRDF fp16 pointwise, worst at " << pointwise[1].worst;
      for (int h = 0; h < 2; ++h)
        report_["terms"].push_back({{"term", "DirectBRDF (white metal, _MULTISCATTER)"}, {"probe", "PROBE_DIRECT"},
                                    {"precision", h ? "fp16" : "fp32"}, {"points", pointwise[h].points},
                                    {"max", pointwise[h].max_error}, {"mean", 0.0}, {"bound", h ? 1e-2 : 1e-5},
                                    {"worst", pointwise[h].worst}});
    }
    for (size_t c = 0; c < cells.size(); ++c) {
      const DirectCell& cell = cells[c];
      // outputs: 0 metal, 1 dielectric, 2 AccumulateLight(metal, 1 lux)
      std::array<double, 3> e32{}, e16{};
      double e_ref = 0;
      for (uint32_t i = 0; i < samples; ++i) {
        double w = cell.inverse_pdf[i] / samples;
        const size_t k = c * samples + i;
        for (int o = 0; o < 3; ++o) e32[o] += full[k][o] * w, e16[o] += half[k][o] * w;
        e_ref += cell.reference[i] * w;
      }
      // Metal and dielectric: the fp16 energy within 2% of fp32's (issue 23's target), on fp16's domain.
      for (int o = 0; o < 2; ++o) {
        double error = e16[o] / e32[o] - 1;
        worst16 = std::max(worst16, std::abs(error));
        EXPECT_LE(std::abs(error), 0.02) << name << (o ? " dielectric" : " metal") << " roughness " << cell.roughness
                                         << " NoV " << cell.NoV << ": fp32 energy " << e32[o] << ", fp16 " << e16[o];
      }
      worst_accumulate = std::max(worst_accumulate, std::abs(e16[2] / e32[2] - 1));
      // fp32 against the double reference at the same points (with _MULTISCATTER the metal's energy is ~1):
      // within 1e-5 (measured 1.7e-7).
      if (name == "_MULTISCATTER") {
        double error = e32[0] / e_ref - 1;
        worst32 = std::max(worst32, std::abs(error));
        EXPECT_LE(std::abs(error), 1e-5) << "fp32 metal roughness " << cell.roughness << " NoV " << cell.NoV
                                         << ": GPU energy " << e32[0] << ", double " << e_ref;
        entry["cells"].push_back({{"roughness", cell.roughness}, {"NoV", cell.NoV}, {"energy_fp32", e32[0]},
                                  {"energy_fp16", e16[0]}, {"energy_double", e_ref},
                                  {"accumulate_fp16_over_fp32", e16[2] / e32[2]}});
      }
    }
    entry["keywords"][name] = {{"max_relative_fp16_vs_fp32", worst16},
                               {"max_relative_accumulate_fp16_vs_fp32", worst_accumulate}};
    if (name == "_MULTISCATTER") entry["max_relative_fp32_vs_double"] = worst32;
  }
  entry["samples_per_cell"] = samples;
  report_["direct_energy"] = entry;
}

//------------------------------------------------------------------------------------------------------------
// Issue 23, item 2: the DFG table at grazing angles, against an integrator that is not its generator.
//------------------------------------------------------------------------------------------------------------

// The table is made by GGX importance sampling (ref::DFG); the truth here is ref::DFGQuadrature (a midpoint
// product rule over the half vectors, Smith's Lambda form), itself checked against the closed form at alpha = 1
// in tests/unit/reference_test.cpp. Its own error at these settings (nx = 1024): at most about 2e-4 at grazing
// NoV (reference.hpp), a twentieth of the bound.
struct DfgTruth {
  std::vector<double> roughness, nov;
  std::vector<std::array<double, 2>> dfg;  // [roughness][NoV]
};

const DfgTruth& dfg_truth() {
  static const DfgTruth truth = [] {
    DfgTruth t;
    // Every roughness: authored values from 0 (below the floors: the shaders look the table up at the clamped
    // roughness) to 1, and the points halfway between the table's rows, where interpolation errs most.
    for (int j = 0; j <= 63; ++j) t.roughness.push_back(j / 63.0);
    for (int j = 0; j < 63; ++j) t.roughness.push_back(ref::DfgRowPerceptualRoughness((j + 0.5) / 63.0));
    t.roughness.push_back(kMinRoughnessFp32);
    t.roughness.push_back(kMinRoughnessFp16);
    // NoV from the 0.005 to 1, log-spaced, plus the dip's neighbourhood.
    t.nov = log_spaced(0.005, 1.0, 32);
    for (double v : {0.006, 0.007, 0.008, 0.009, 0.011, 0.013}) t.nov.push_back(v);
    t.dfg.resize(t.roughness.size() * t.nov.size());
    kiln::parallel_for(t.dfg.size(), std::max(1u, std::thread::hardware_concurrency()), [&](size_t k) {
      double r = t.roughness[k / t.nov.size()], v = double(float(t.nov[k % t.nov.size()]));
      // The lobe the fp32 BRDF evaluates (clamped at 0.045); fp16 variants are compared from their floor, 0.089.
      t.dfg[k] = ref::DFGQuadrature(v, ref::PerceptualRoughnessToAlpha(double(float(r))), 1024, 64);
    });
    return t;
  }();
  return truth;
}

TEST_F(Accuracy, DfgTableAsTheShadersSampleItIsWithinHalfAPercentOfAnIndependentIntegrator) {
  const DfgTruth& truth = dfg_truth();
  const ref::DfgTable table = shipped_dfg_table();
  std::vector<ProbeInput> records;
  for (double r : truth.roughness)
    for (double v : truth.nov) {
      ProbeInput p{};
      p[0] = float(r), p[1] = float(v);
      records.push_back(p);
    }
  nlohmann::json entry;
  for (bool half : {false, true}) {
    std::vector<std::string> defines = {"PROBE_TABLE"};
    if (half) defines.push_back("_HALF_PRECISION");
    auto out = run(defines, records, table_texture(table));
    ASSERT_EQ(out.size(), records.size());
    // The bound, 0.005 in albedo, for NoV >= 0.005, at f0 = 0 (dfg.x), 0.04 and 1 (dfg.y); fp16
    // variants sample the same fp32 texture and round the result to fp16 (4.9e-4 at 1), within the same bound.
    const double bound = 0.005;
    double worst = 0;
    std::string where;
    for (size_t k = 0; k < records.size(); ++k) {
      if (half && truth.roughness[k / truth.nov.size()] < kMinRoughnessFp16) continue;  // another lobe by design
      const auto& t = truth.dfg[k];
      for (double f0 : {0.0, 0.04, 1.0}) {
        double looked_up = out[k][0] + (out[k][1] - out[k][0]) * f0;
        double expected = t[0] + (t[1] - t[0]) * f0;
        double error = std::abs(looked_up - expected);
        if (error > worst) {
          worst = error;
          where = "roughness " + std::to_string(truth.roughness[k / truth.nov.size()]) + " NoV " +
                  std::to_string(truth.nov[k % truth.nov.size()]) + " f0 " + std::to_string(f0) + ": table " +
                  std::to_string(looked_up) + ", integral " + std::to_string(expected);
        }
      }
    }
    EXPECT_LE(worst, bound) << (half ? "fp16" : "fp32") << " worst at " << where;
    entry[half ? "fp16" : "fp32"] = {{"max_abs_albedo_error", worst}, {"bound", bound}, {"where", where}};
  }
  entry["points"] = records.size();
  report_["dfg_lookup"] = entry;
}

// The white furnace with _MULTISCATTER: the true single-scattering albedo of a white (f0 = 1) surface times the
// compensation EnergyCompensation computes on the GPU from the table is 1 (Kulla-Conty via Filament).
TEST_F(Accuracy, MultiscatterWhiteFurnaceIsWithinOnePercentForNoVFromOneHundredth) {
  const DfgTruth& truth = dfg_truth();
  const ref::DfgTable table = shipped_dfg_table();
  std::vector<ProbeInput> records;
  for (double r : truth.roughness)
    for (double v : truth.nov) {
      ProbeInput p{};
      p[0] = float(r), p[1] = float(v), p[5] = 1.0f;  // b.y = f0
      records.push_back(p);
    }
  nlohmann::json entry;
  for (bool half : {false, true}) {
    std::vector<std::string> defines = {"PROBE_TERM", "TERM_ENERGY_COMPENSATION", "PROBE_USES_TABLE"};
    if (half) defines.push_back("_HALF_PRECISION");
    auto out = run(defines, records, table_texture(table));
    ASSERT_EQ(out.size(), records.size());
    double worst = 0, worst_below = 0;
    std::string where;
    for (size_t k = 0; k < records.size(); ++k) {
      if (half && truth.roughness[k / truth.nov.size()] < kMinRoughnessFp16) continue;  // another lobe by design
      double v = truth.nov[k % truth.nov.size()];
      double error = std::abs(truth.dfg[k][1] * out[k][0] - 1);
      if (v < 0.01) {
        worst_below = std::max(worst_below, error);
        continue;
      }
      if (error > worst) {
        worst = error;
        where = "roughness " + std::to_string(truth.roughness[k / truth.nov.size()]) + " NoV " + std::to_string(v) +
                ": energy " + std::to_string(truth.dfg[k][1] * out[k][0]);
      }
    }
    EXPECT_LE(worst, 0.01) << (half ? "fp16" : "fp32") << " worst at " << where;
    entry[half ? "fp16" : "fp32"] = {{"max_abs_energy_error_nov_from_0.01", worst}, {"where", where},
                                     {"max_abs_energy_error_nov_0.005_to_0.01", worst_below}};
  }
  report_["white_furnace"] = entry;
}

}  // namespace
}  // namespace kiln::gpu
