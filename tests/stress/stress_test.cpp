// SPDX-License-Identifier: Apache-2.0
// The numerical stress gate (ctest label `stress`): shaderlib's public functions and the full lit shading,
// compiled by kiln's front end and run on lavapipe over a grid of at least 5,000 points plus the special
// cases (roughness 0 and tiny; NoV, NoL 0 and 1e-8; NoH 1 and 1 - 1 ulp; light distance 0; zero-length
// normal and light vectors; equal spot angles; intensities and tone-map inputs up to 1e5; anisotropy +-1),
// in fp32 and in explicit fp16. The gate: zero NaN, zero Inf, zero negative outputs. The unguarded
// textbook kernel runs through the same harness and must fail, which proves the gate can see failures.
// Also measures where fp16 loses accuracy against fp32 and writes both to a JSON report for bench/REPORT.md.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>

#include "lavapipe_suite.hpp"
#include "probe/lavapipe.hpp"

namespace kiln::gpu {
namespace {

const std::filesystem::path kShaderlib = std::filesystem::path(KILN_SOURCE_DIR) / "shaderlib";
const std::filesystem::path kProbe = std::filesystem::path(KILN_SOURCE_DIR) / "tests/gpu/Probe.hlsl";

const float kOneMinusUlp = std::nextafter(1.0f, 0.0f);

// The special values of the issue, on every axis they apply to.
const std::vector<float> kRoughness = {0.0f, 1e-8f, 1e-4f, 0.01f, 0.045f, 0.089f, 0.1f, 0.25f, 0.5f, 0.75f, 1.0f};
const std::vector<float> kCosine = {0.0f, 1e-8f, 1e-4f, 1e-3f, 3e-3f, 0.01f, 0.1f, 0.5f, 0.9f, 1.0f};
const std::vector<float> kNoH = {0.0f, 0.5f, 0.9f, 0.999f, kOneMinusUlp, 1.0f};
const std::vector<float> kF0 = {0.0f, 0.04f, 1.0f};
const std::vector<float> kLoH = {0.0f, 1e-8f, 0.5f, kOneMinusUlp, 1.0f};
const std::vector<float> kAnisotropy = {-1.0f, -0.5f, 0.0f, 0.5f, 1.0f};
const std::vector<float> kPhi = {0.0f, 0.7853982f, 1.5707964f};
const std::vector<float> kDfg = {0.0f, 1e-4f, 0.3f, 1.0f};
const std::vector<float> kToneMapInput = {-1e5f, -1.0f, 0.0f, 1e-8f, 0.18f, 1.0f, 30.0f, 1e3f, 1e5f};

// fp16 variants clamp roughness at 0.089 and fp32 at 0.045 (Common.hlsl), so below 0.089 they evaluate
// different lobes by design; the anisotropic lobe's narrow axis, alpha (1 - |anisotropy|), has the same floor.
bool above_fp16_roughness_floor(float roughness, float anisotropy) {
  const float floor_alpha = 0.089f * 0.089f;
  return roughness >= 0.089f && roughness * roughness * (1.0f - std::abs(anisotropy)) >= floor_alpha;
}

struct Grid {
  std::vector<ProbeInput> points;
  std::vector<bool> safe;  // inside the range where fp16 is compared with fp32
};

// a = (roughness, NoV, NoL, NoH), b = (LoH, f0, anisotropy, phi), c = (dfg.x, dfg.y, -, -), d = tone-map input.
Grid term_grid() {
  Grid grid;
  size_t i = 0;
  for (float r : kRoughness)
    for (float nov : kCosine)
      for (float nol : kCosine)
        for (float noh : kNoH)
          for (float f0 : kF0) {
            ProbeInput p{};
            p[0] = r, p[1] = nov, p[2] = nol, p[3] = noh;
            p[4] = kLoH[i % kLoH.size()], p[5] = f0, p[6] = kAnisotropy[i % kAnisotropy.size()];
            p[7] = kPhi[(i / 5) % kPhi.size()];
            p[8] = kDfg[i % kDfg.size()], p[9] = kDfg[(i / 4) % kDfg.size()];
            float tone = kToneMapInput[i % kToneMapInput.size()];
            p[12] = tone, p[13] = tone * 0.5f, p[14] = -tone * 0.25f;
            grid.points.push_back(p);
            // fp16's domain (issue 23): NoV and NoL down to 1e-3, grazing included.
            grid.safe.push_back(above_fp16_roughness_floor(r, p[6]) && nov >= 1e-3f && nol >= 1e-3f);
            ++i;
          }
  return grid;
}

// c = (distance^2, 1/range^2, cos inner, cos outer), d = (cos to the spot axis, kelvin, lumens, -).
Grid light_grid() {
  const std::vector<float> distance2 = {0.0f, 1e-12f, 1e-4f, 0.25f, 1.0f, 100.0f, 1e4f};
  const std::vector<float> inverse_range2 = {0.0f, 1e-2f, 1.0f, 1e4f};
  const std::vector<std::pair<float, float>> cones = {{0.9f, 0.9f}, {0.95f, 0.9f}, {1.0f, 1.0f}, {0.0f, 0.0f}, {-1.0f, -1.0f}};
  const std::vector<float> cos_theta = {-1.0f, 0.0f, 0.9f, 0.95f, 1.0f};
  const std::vector<float> kelvin = {0.0f, 1000.0f, 6500.0f, 6570.0f, 6600.0f, 40000.0f, 1e5f};
  const std::vector<float> lumens = {0.0f, 1.0f, 1e5f};
  Grid grid;
  size_t i = 0;
  for (float d2 : distance2)
    for (float ir2 : inverse_range2)
      for (auto [inner, outer] : cones)
        for (float ct : cos_theta)
          for (float k : kelvin) {
            ProbeInput p{};
            p[8] = d2, p[9] = ir2, p[10] = inner, p[11] = outer;
            p[12] = ct, p[13] = k, p[14] = lumens[i++ % lumens.size()];
            grid.points.push_back(p);
            grid.safe.push_back(true);
          }
  return grid;
}

// a = (roughness, metallic, anisotropy, intensity), b = (normal, dfg.x), c = (to eye, dfg.y), d = (to light, kind).
Grid lit_grid() {
  const std::vector<std::array<float, 3>> normals = {
      {0, 0, 0}, {0, 1, 0}, {1e-12f, 0, 0}, {0.3f, 0.9f, 0.1f}, {0, -1, 0}};
  const std::vector<std::array<float, 3>> views = {{0, 0, 0}, {0, 1, 0}, {1, 1e-8f, 0}, {0.2f, 0.7f, -0.4f}, {0, -1, 0}};
  const std::vector<std::array<float, 3>> lights = {
      {0, 0, 0}, {0, 1, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1e-8f, 0}, {0, 1e4f, 0}, {0.3f, 0.5f, 0.2f}};
  const std::vector<float> kinds = {0.0f, 1.0f, 2.0f};
  const std::vector<float> intensities = {0.0f, 1e-6f, 1.0f, 1e3f, 1e5f};
  const std::vector<float> metallic = {0.0f, 1.0f};
  Grid grid;
  size_t i = 0;
  for (float r : kRoughness)
    for (const auto& n : normals)
      for (const auto& v : views)
        for (const auto& l : lights)
          for (float kind : kinds) {
            ProbeInput p{};
            float intensity = intensities[i % intensities.size()];
            p[0] = r, p[1] = metallic[(i / 5) % 2], p[2] = kAnisotropy[i % kAnisotropy.size()], p[3] = intensity;
            p[4] = n[0], p[5] = n[1], p[6] = n[2], p[7] = kDfg[i % kDfg.size()];
            p[8] = v[0], p[9] = v[1], p[10] = v[2], p[11] = kDfg[(i / 4) % kDfg.size()];
            p[12] = l[0], p[13] = l[1], p[14] = l[2], p[15] = kind;
            // Safe for fp16: non-degenerate frame, light in range, and illuminance an fp16 renderer would see
            // after pre-exposure (<= 1e3).
            bool degenerate = n[0] + n[1] + n[2] == 0 || n[0] == 1e-12f || v[0] + v[1] + v[2] == 0;
            bool light_ok = l[0] + l[1] + l[2] != 0 && l[1] != 1e-8f && l[1] != 1e4f;
            grid.points.push_back(p);
            grid.safe.push_back(!degenerate && light_ok && above_fp16_roughness_floor(r, p[2]) && intensity <= 1e3f &&
                                p[7] > 0.1f && p[11] > 0.1f);
            ++i;
          }
  return grid;
}

// a = (roughness, NoV, dfg.x, dfg.y), b = (towards the light, -), c = (towards the eye, -): DirectBRDF in the
// frame N = +Z, V in the x-z plane.
// The light directions: around the mirror direction (where a smooth lobe peaks), grazing (NoL 1e-3 and 1e-8),
// along N, behind the surface, and L = -V (no half vector).
Grid direct_grid() {
  Grid grid;
  size_t i = 0;
  for (float r : kRoughness)
    for (float nov : kCosine) {
      const float sinV = std::sqrt(std::max(0.0f, 1.0f - nov * nov));
      std::vector<std::array<float, 3>> lights = {{-sinV, 0, nov}, {0, 0, 1}, {0, 0, -1}, {-sinV, 0, -nov}};
      for (float nol : {1e-8f, 1e-3f, 3e-3f, 0.01f, 0.1f, 0.5f}) {
        const float sinL = std::sqrt(1.0f - nol * nol);
        lights.push_back({-sinL, 0, nol});                        // mirror azimuth
        lights.push_back({-sinL * 0.99955f, sinL * 0.03f, nol});  // 1.7 degrees off it
        lights.push_back({0, sinL, nol});                         // 90 degrees off it
      }
      for (const auto& l : lights) {
        ProbeInput p{};
        p[0] = r, p[1] = nov, p[2] = kDfg[i % kDfg.size()], p[3] = kDfg[(i / 4) % kDfg.size()];
        p[4] = l[0], p[5] = l[1], p[6] = l[2];
        p[8] = sinV, p[10] = nov;
        grid.points.push_back(p);
        grid.safe.push_back(above_fp16_roughness_floor(r, 0) && nov >= 1e-3f && l[2] >= 1e-3f && p[3] > 0.1f);
        ++i;
      }
    }
  return grid;
}

struct BadCounts {
  size_t nan = 0, inf = 0, negative = 0;
  std::string first;  // the first failing record and output, for the failure message
  size_t total() const { return nan + inf + negative; }
};

std::string describe(const ProbeInput& p) {
  std::string s = "a=(";
  for (int k = 0; k < 16; ++k) {
    s += std::to_string(p[k]);
    s += (k % 4 == 3) ? (k == 15 ? ")" : ") " + std::string(1, "abcd"[k / 4 + 1]) + "=(") : ", ";
  }
  return s;
}

BadCounts count_bad(const std::vector<ProbeInput>& in, const std::vector<ProbeOutput>& out) {
  BadCounts counts;
  for (size_t i = 0; i < out.size(); ++i)
    for (int k = 0; k < 4; ++k) {
      float v = out[i][k];
      bool bad = true;
      if (std::isnan(v)) ++counts.nan;
      else if (std::isinf(v)) ++counts.inf;
      else if (v < 0) ++counts.negative;
      else bad = false;
      if (bad && counts.first.empty())
        counts.first = "output " + std::to_string(k) + " = " + std::to_string(v) + " at " + describe(in[i]);
    }
  return counts;
}

struct Fp16Loss {
  std::array<double, 4> mean{}, p99{}, max{};
  std::array<std::string, 4> worst;  // where the max is reached: record, fp32 and fp16 values
  size_t points = 0;
};

// Relative error of fp16 against fp32 over the safe points, for outputs whose fp32 value fp16 can represent
// (|x| <= 65504); magnitudes below 1e-3 count as 1e-3 (absolute error there), so values that are ~0 in both
// do not produce meaningless huge ratios.
Fp16Loss fp16_loss(const Grid& grid, const std::vector<ProbeOutput>& full, const std::vector<ProbeOutput>& half) {
  Fp16Loss loss;
  std::array<std::vector<double>, 4> errors;
  for (size_t i = 0; i < grid.points.size(); ++i) {
    if (!grid.safe[i]) continue;
    ++loss.points;
    for (int k = 0; k < 4; ++k) {
      if (std::abs(full[i][k]) > 65504.0f) continue;  // beyond fp16's range: nothing to compare
      double e = std::abs(double(half[i][k]) - full[i][k]) / std::max(std::abs(double(full[i][k])), 1e-3);
      if (errors[k].empty() || e > *std::max_element(errors[k].begin(), errors[k].end()))
        loss.worst[k] = describe(grid.points[i]) + ": fp32 " + std::to_string(full[i][k]) + ", fp16 " +
                        std::to_string(half[i][k]);
      errors[k].push_back(e);
    }
  }
  for (int k = 0; k < 4; ++k) {
    auto& e = errors[k];
    if (e.empty()) continue;
    std::sort(e.begin(), e.end());
    double sum = 0;
    for (double x : e) sum += x;
    loss.mean[k] = sum / double(e.size());
    loss.p99[k] = e[std::min(e.size() - 1, size_t(double(e.size()) * 0.99))];
    loss.max[k] = e.back();
  }
  return loss;
}

class Stress : public LavapipeSuite<Stress> {
 public:
  static constexpr const char* kReportEnvironment = "KILN_STRESS_REPORT";  // bench/run_all.sh points it into bench/results/
  static constexpr const char* kReportPath = KILN_STRESS_REPORT_PATH;

 protected:
  std::vector<ProbeOutput> run(const std::string& probe, std::vector<std::string> defines, const Grid& grid) {
    defines.push_back(probe);
    auto program = compile_probe(kProbe, {kShaderlib}, defines);
    EXPECT_TRUE(program) << program.error().message;
    if (!program) return {};
    return gpu_->run(*program, grid.points);
  }

  // Runs `probe` in fp32 and fp16 with `keywords`, asserts the gate on both, records counts and fp16 loss.
  void gate(const std::string& probe, const std::vector<std::string>& keywords, const Grid& grid,
            const std::array<const char*, 4>& outputs) {
    std::string name = probe;
    for (const auto& k : keywords) name += " " + k;
    auto full = run(probe, keywords, grid);
    auto with_half = keywords;
    with_half.push_back("_HALF_PRECISION");
    auto half = run(probe, with_half, grid);
    ASSERT_EQ(full.size(), grid.points.size());
    ASSERT_EQ(half.size(), grid.points.size());
    BadCounts bad32 = count_bad(grid.points, full);
    BadCounts bad16 = count_bad(grid.points, half);
    EXPECT_EQ(bad32.total(), 0u) << name << " fp32: " << bad32.nan << " NaN, " << bad32.inf << " Inf, "
                                 << bad32.negative << " negative; first: " << bad32.first;
    EXPECT_EQ(bad16.total(), 0u) << name << " fp16: " << bad16.nan << " NaN, " << bad16.inf << " Inf, "
                                 << bad16.negative << " negative; first: " << bad16.first;
    Fp16Loss loss = fp16_loss(grid, full, half);
    nlohmann::json entry;
    entry["probe"] = name;
    entry["points"] = grid.points.size();
    entry["fp32"] = {{"nan", bad32.nan}, {"inf", bad32.inf}, {"negative", bad32.negative}};
    entry["fp16"] = {{"nan", bad16.nan}, {"inf", bad16.inf}, {"negative", bad16.negative}};
    entry["fp16_loss_points"] = loss.points;
    for (int k = 0; k < 4; ++k)
      entry["fp16_loss"].push_back(
          {{"output", outputs[k]}, {"mean", loss.mean[k]}, {"p99", loss.p99[k]}, {"max", loss.max[k]}, {"worst", loss.worst[k]}});
    report_["gates"].push_back(entry);
  }

};


TEST_F(Stress, GridsCoverTheSpecialCasesWithAtLeast5000Points) {
  EXPECT_GE(term_grid().points.size(), 5000u);
  EXPECT_GE(lit_grid().points.size(), 5000u);
  EXPECT_GE(light_grid().points.size(), 4000u);
}

TEST_F(Stress, SpecularTermsHaveNoNanInfOrNegative) {
  gate("PROBE_SPECULAR", {}, term_grid(), {"D_GGX", "V_SmithGGXCorrelated", "V_SmithGGXCorrelated_Fast", "F_Schlick"});
}

TEST_F(Stress, SeparableAnisotropicAndPowTermsHaveNoNanInfOrNegative) {
  gate("PROBE_SPECULAR_MORE", {}, term_grid(),
       {"V_SmithGGX_Separable", "F_Schlick_Pow", "D_GGX_Anisotropic", "V_SmithGGXCorrelated_Anisotropic"});
}

TEST_F(Stress, DiffuseTermsHaveNoNanInfOrNegative) {
  gate("PROBE_DIFFUSE", {}, term_grid(), {"Fd_Lambert", "Fd_Burley", "Fd_RenormalizedBurley", "V_Kelemen_UnityMobile"});
}

TEST_F(Stress, LightFunctionsHaveNoNanInfOrNegative) {
  gate("PROBE_LIGHTS", {}, light_grid(),
       {"DistanceAttenuation", "SpotAttenuation", "SpotLightLumensToCandela", "ColorTemperatureToLinearRGB"});
}

TEST_F(Stress, IblAndToneMappingHaveNoNanInfOrNegative) {
  gate("PROBE_IBL", {}, term_grid(), {"EnvBRDFApprox", "EnergyCompensation", "SpecularDFG", "ACESFitted"});
}

TEST_F(Stress, DirectLightingOfOneLightHasNoNanInfOrNegative) {
  EXPECT_GE(direct_grid().points.size(), 2000u);
  for (std::vector<std::string> keywords : std::vector<std::vector<std::string>>{{}, {"_MULTISCATTER"}})
    gate("PROBE_DIRECT", keywords, direct_grid(), {"DirectBRDF (metal)", "DirectBRDF (dielectric)", "AccumulateLight (metal, 1 lux)", "-"});
}

TEST_F(Stress, FullLitShadingHasNoNanInfOrNegativeInEveryShadingModel) {
  Grid grid = lit_grid();
  const std::array<const char*, 4> outputs = {"radiance.r", "radiance.g", "radiance.b", "ACES(radiance).g"};
  for (std::vector<std::string> keywords : std::vector<std::vector<std::string>>{
           {}, {"_DIFFUSE_BURLEY", "_MULTISCATTER"}, {"_ANISOTROPY"}, {"_MOBILE_BRDF"}, {"_ENV_BRDF_APPROX"},
           {"_SPECULARHIGHLIGHTS_OFF"}}) {
    SCOPED_TRACE(testing::Message() << keywords.size() << " keywords");
    gate("PROBE_LIT", keywords, grid, outputs);
  }
}

// Sensitivity: the same harness must see the textbook kernel's failures, or a passing gate means nothing.
TEST_F(Stress, UnguardedTextbookKernelFailsTheSameGrid) {
  Grid grid = term_grid();
  auto full = run("PROBE_TEXTBOOK", {}, grid);
  auto half = run("PROBE_TEXTBOOK", {"_HALF_PRECISION"}, grid);
  BadCounts bad32 = count_bad(grid.points, full);
  BadCounts bad16 = count_bad(grid.points, half);
  EXPECT_GT(bad32.nan + bad32.inf, 100u) << "the harness no longer detects the textbook kernel's NaN/Inf";
  EXPECT_GT(bad16.nan + bad16.inf, bad32.nan + bad32.inf) << "fp16 should fail more often than fp32";
  report_["textbook"] = {{"points", grid.points.size()},
                         {"fp32", {{"nan", bad32.nan}, {"inf", bad32.inf}, {"negative", bad32.negative}}},
                         {"fp16", {{"nan", bad16.nan}, {"inf", bad16.inf}, {"negative", bad16.negative}}}};
}

}  // namespace
}  // namespace kiln::gpu

namespace kiln::gpu {
namespace {

// The study's cost axis (weighted SPIR-V instruction count) on probes whose relation is known: pow costs
// more than the multiply chain it replaces, a table lookup is one texture fetch, an empty term costs nothing
// beyond the record fetch.
TEST(CostModel, WeightedCountsRankKnownPairsAndCountFetches) {
  auto cost_of = [&](std::vector<std::string> defines) {
    defines.push_back("PROBE_TERM");
    auto program = compile_probe(kProbe, {kShaderlib}, defines);
    EXPECT_TRUE(program) << program.error().message;
    return program ? weighted_cost(program->fragment) : ShaderCost{};
  };
  ShaderCost none = cost_of({"TERM_NONE"});
  ShaderCost chain = cost_of({"TERM_F_SCHLICK"});
  ShaderCost pow = cost_of({"TERM_F_SCHLICK_POW"});
  ShaderCost table = cost_of({"TERM_ENV_TABLE", "PROBE_USES_TABLE"});
  EXPECT_GT(chain.weighted, none.weighted);
  EXPECT_GE(pow.weighted, chain.weighted + 9.0);  // at least the pow itself on top of the chain's work
  EXPECT_EQ(none.texture_fetches, 0u);
  EXPECT_EQ(table.texture_fetches, 1u);
}

}  // namespace
}  // namespace kiln::gpu
