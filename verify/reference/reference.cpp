// SPDX-License-Identifier: Apache-2.0
#include "reference/reference.hpp"
#include "scene/verify_error.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace kiln::reference {

double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

Vec3 normalize(Vec3 v) {
  double length = std::sqrt(dot(v, v));
  return length > 0 ? v * (1.0 / length) : Vec3{0, 0, 1};
}

double PerceptualRoughnessToAlpha(double perceptualRoughness, double minimum) {
  double r = std::clamp(perceptualRoughness, minimum, 1.0);
  return r * r;
}

double ComputeF0(double baseColor, double metallic, double reflectance) {
  double dielectric = 0.16 * reflectance * reflectance;
  return dielectric + (baseColor - dielectric) * metallic;
}

double D_GGX(double NoH, double a) {
  double a2 = a * a;
  double d = (NoH * a2 - NoH) * NoH + 1.0;
  return a2 / (kPi * d * d);
}

double D_GGX_Anisotropic(double NoH, double ToH, double BoH, double at, double ab) {
  double a2 = at * ab;
  double dx = ab * ToH, dy = at * BoH, dz = a2 * NoH;
  double d2 = dx * dx + dy * dy + dz * dz;
  double b2 = a2 / d2;
  return a2 * b2 * b2 / kPi;
}

double V_SmithGGXCorrelated(double NoV, double NoL, double a) {
  double a2 = a * a;
  double GGXV = NoL * std::sqrt(NoV * NoV * (1.0 - a2) + a2);
  double GGXL = NoV * std::sqrt(NoL * NoL * (1.0 - a2) + a2);
  return 0.5 / (GGXV + GGXL);
}

double V_SmithGGXCorrelated_Fast(double NoV, double NoL, double a) {
  return 0.5 / ((2.0 * NoL * NoV) * (1.0 - a) + (NoL + NoV) * a);
}

double V_SmithGGX_Separable(double NoV, double NoL, double a) {
  double a2 = a * a;
  double GV = NoV + std::sqrt(NoV * NoV * (1.0 - a2) + a2);
  double GL = NoL + std::sqrt(NoL * NoL * (1.0 - a2) + a2);
  return 1.0 / (GV * GL);
}

double V_SmithGGXCorrelated_Anisotropic(double at, double ab, double ToV, double BoV, double ToL, double BoL, double NoV,
                                        double NoL) {
  double lambdaV = NoL * std::sqrt(at * at * ToV * ToV + ab * ab * BoV * BoV + NoV * NoV);
  double lambdaL = NoV * std::sqrt(at * at * ToL * ToL + ab * ab * BoL * BoL + NoL * NoL);
  return 0.5 / (lambdaV + lambdaL);
}

double F_Schlick(double f0, double f90, double VoH) { return f0 + (f90 - f0) * std::pow(1.0 - VoH, 5.0); }

double Fd_Lambert() { return 1.0 / kPi; }

double Fd_Burley(double NoV, double NoL, double LoH, double perceptualRoughness) {
  double f90 = 0.5 + 2.0 * perceptualRoughness * LoH * LoH;
  return F_Schlick(1.0, f90, NoL) * F_Schlick(1.0, f90, NoV) / kPi;
}

double Fd_RenormalizedBurley(double NoV, double NoL, double LoH, double perceptualRoughness) {
  double energyBias = 0.5 * perceptualRoughness;
  double energyFactor = 1.0 + (1.0 / 1.51 - 1.0) * perceptualRoughness;
  double fd90 = energyBias + 2.0 * LoH * LoH * perceptualRoughness;
  return F_Schlick(1.0, fd90, NoL) * F_Schlick(1.0, fd90, NoV) * energyFactor / kPi;
}

std::array<double, 2> EnvBRDFApprox(double perceptualRoughness, double NoV) {
  const double c0[4] = {-1.0, -0.0275, -0.572, 0.022};
  const double c1[4] = {1.0, 0.0425, 1.04, -0.04};
  double r[4];
  for (int i = 0; i < 4; ++i) r[i] = perceptualRoughness * c0[i] + c1[i];
  double a004 = std::min(r[0] * r[0], std::exp2(-9.28 * NoV)) * r[0] + r[1];
  return {-1.04 * a004 + r[2], 1.04 * a004 + r[3]};
}

double EnergyCompensation(double dfgY, double f0) { return 1.0 + f0 * (1.0 / dfgY - 1.0); }

double DistanceWindow(double distanceSquared, double inverseRangeSquared) {
  double factor = distanceSquared * inverseRangeSquared;
  double smooth = std::clamp(1.0 - factor * factor, 0.0, 1.0);
  return smooth * smooth;
}

double DistanceAttenuation(double distanceSquared, double inverseRangeSquared) {
  return DistanceWindow(distanceSquared, inverseRangeSquared) / std::max(distanceSquared, 1e-4);
}

double SpotAttenuation(double cosTheta, double cosInner, double cosOuter) {
  double scale = 1.0 / std::max(cosInner - cosOuter, 1e-4);
  double a = std::clamp((cosTheta - cosOuter) * scale, 0.0, 1.0);
  return a * a;
}

std::array<double, 3> ColorTemperatureToLinearRGB(double temperature) {
  double k = std::clamp(temperature, 1000.0, 40000.0) / 1000.0, k2 = k * k;
  auto sat = [](double x) { return std::clamp(x, 0.0, 1.0); };
  double r = k < 6.570 ? 1.0 : sat((1.35651 + 0.216422 * k + 0.000633715 * k2) / (-3.24223 + 0.918711 * k));
  double g = k < 6.570 ? sat((-399.809 + 414.271 * k + 111.543 * k2) / (2779.24 + 164.143 * k + 84.7356 * k2))
                       : sat((1370.38 + 734.616 * k + 0.689955 * k2) / (-4625.69 + 1699.87 * k));
  double b = k > 6.570 ? 1.0 : sat((348.963 - 523.53 * k + 183.62 * k2) / (2848.82 - 214.52 * k + 78.8614 * k2));
  return {r, g, b};
}

double FogFactorLinear(double depth, double start, double end) {
  // Equal planes: a hard step at the plane (the shader floors end - start at 1e-4 for the same reason).
  return std::clamp((end - depth) / std::max(end - start, 1e-4), 0.0, 1.0);
}

double FogFactorExp(double depth, double density) { return std::clamp(std::exp(-density * depth), 0.0, 1.0); }

double FogFactorExp2(double depth, double density) {
  return std::clamp(std::exp(-(density * depth) * (density * depth)), 0.0, 1.0);
}

double MixFog(double color, double fog_color, double factor) { return fog_color + (color - fog_color) * factor; }

std::array<double, 3> ACESFitted(std::array<double, 3> c) {
  // NaN -> 0 like the shader's max-based guard on GPUs that return the non-NaN operand.
  for (double& v : c) v = std::isnan(v) ? 0.0 : std::clamp(v, 0.0, 1e5);
  const double in[3][3] = {{0.59719, 0.35458, 0.04823}, {0.07600, 0.90834, 0.01566}, {0.02840, 0.13383, 0.83777}};
  const double out[3][3] = {{1.60475, -0.53108, -0.07367}, {-0.10208, 1.10813, -0.00605}, {-0.00327, -0.07276, 1.07602}};
  std::array<double, 3> t{}, r{};
  for (int i = 0; i < 3; ++i) t[i] = in[i][0] * c[0] + in[i][1] * c[1] + in[i][2] * c[2];
  for (double& v : t) v = (v * (v + 0.0245786) - 0.000090537) / (v * (0.983729 * v + 0.4329510) + 0.238081);
  for (int i = 0; i < 3; ++i) r[i] = std::clamp(out[i][0] * t[0] + out[i][1] * t[1] + out[i][2] * t[2], 0.0, 1.0);
  return r;
}

std::array<double, 2> hammersley(uint32_t i, uint32_t count) {
  uint32_t bits = i;
  bits = (bits << 16u) | (bits >> 16u);
  bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
  bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
  bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
  bits = ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
  return {(i + 0.5) / count, bits * 2.3283064365386963e-10};
}

namespace {

// GGX importance sampling of H (pdf = D(h) NoH), Karis 2013.
Vec3 sample_ggx(std::array<double, 2> u, double a) {
  double phi = 2.0 * kPi * u[0];
  double cosTheta = std::sqrt((1.0 - u[1]) / (1.0 + (a * a - 1.0) * u[1]));
  double sinTheta = std::sqrt(std::max(0.0, 1.0 - cosTheta * cosTheta));
  return {sinTheta * std::cos(phi), sinTheta * std::sin(phi), cosTheta};
}

// ∫ f NoL dL over GGX-sampled L, returning (weighted by Fc, unweighted); f = D Vis, F factored out.
std::array<double, 2> integrate_dfg(double NoV, double a, uint32_t samples) {
  Vec3 V{std::sqrt(std::max(0.0, 1.0 - NoV * NoV)), 0.0, NoV};
  double x = 0, y = 0;
  for (uint32_t i = 0; i < samples; ++i) {
    Vec3 H = sample_ggx(hammersley(i, samples), a);
    double VoH = dot(V, H);
    Vec3 L = H * (2.0 * VoH) - V;
    double NoL = L.z, NoH = H.z;
    if (NoL <= 0.0 || VoH <= 0.0) continue;
    // f NoL / pdf(L) = D Vis NoL / (D NoH / (4 VoH)) = 4 Vis NoL VoH / NoH
    double weight = 4.0 * V_SmithGGXCorrelated(NoV, NoL, a) * NoL * VoH / NoH;
    double Fc = std::pow(1.0 - VoH, 5.0);
    x += weight * Fc;
    y += weight;
  }
  return {x / samples, y / samples};
}

}  // namespace

std::array<double, 2> DFG(double NoV, double perceptualRoughness, uint32_t samples) {
  return integrate_dfg(NoV, PerceptualRoughnessToAlpha(perceptualRoughness), samples);
}

double SpecularAlbedo(double NoV, double alpha, double f0, uint32_t samples) {
  auto dfg = integrate_dfg(NoV, alpha, samples);
  return dfg[0] * (1.0 - f0) + dfg[1] * f0;
}

double SpecularAlbedoQuadrature(double NoV, double alpha, double f0, int n) {
  Vec3 V{std::sqrt(std::max(0.0, 1.0 - NoV * NoV)), 0.0, NoV};
  double sum = 0;
  // Cells in (cos theta, phi): dω = d(cos θ) dφ, so the midpoint rule needs no extra Jacobian.
  for (int i = 0; i < n; ++i) {
    double NoL = (i + 0.5) / n;
    double sinTheta = std::sqrt(1.0 - NoL * NoL);
    for (int j = 0; j < n; ++j) {
      double phi = 2.0 * kPi * (j + 0.5) / n;
      Vec3 L{sinTheta * std::cos(phi), sinTheta * std::sin(phi), NoL};
      Vec3 H = normalize(V + L);
      double f = D_GGX(H.z, alpha) * V_SmithGGXCorrelated(NoV, NoL, alpha) * F_Schlick(f0, 1.0, dot(V, H));
      sum += f * NoL;
    }
  }
  return sum * (1.0 / n) * (2.0 * kPi / n);
}

namespace {
// Smith's Lambda for GGX (Heitz 2014, eq. 72): (-1 + sqrt(1 + alpha^2 tan^2(theta))) / 2.
double smith_lambda(double cosTheta, double alpha) {
  double tan2 = (1.0 - cosTheta * cosTheta) / (cosTheta * cosTheta);
  return 0.5 * (-1.0 + std::sqrt(1.0 + alpha * alpha * tan2));
}
}  // namespace

std::array<double, 2> DFGQuadrature(double NoV, double alpha, int nx, int nphi) {
  // E = ∫ D(h) G2(V, L) F(VoH) VoH / NoV dω_h over the half vectors with VoH > 0 and NoL > 0
  // (f NoL dω_L = D G2 F / (4 NoV NoL) NoL 4 VoH dω_h). V lies in the x-z plane, so the integrand is even in
  // φ: integrate φ over [0, π] and double.
  const double sinV = std::sqrt(std::max(0.0, 1.0 - NoV * NoV));
  const double lambdaV = smith_lambda(NoV, alpha);
  double x_sum = 0, y_sum = 0;
  for (int i = 0; i < nx; ++i) {
    double s = std::tan(0.5 * kPi * (i + 0.5) / nx);
    double tanTheta = alpha * s;
    double cosTheta = 1.0 / std::sqrt(1.0 + tanTheta * tanTheta);
    double sinTheta = tanTheta * cosTheta;
    double weight = s / (2.0 * cosTheta * (1.0 + s * s));  // D(h) dω_h per dx dφ
    for (int j = 0; j < nphi; ++j) {
      double phi = kPi * (j + 0.5) / nphi;
      double VoH = sinV * sinTheta * std::cos(phi) + NoV * cosTheta;
      if (VoH <= 0.0) continue;
      double NoL = 2.0 * VoH * cosTheta - NoV;
      if (NoL <= 0.0) continue;
      double f = weight * VoH / (NoV * (1.0 + lambdaV + smith_lambda(NoL, alpha)));
      double Fc = std::pow(1.0 - VoH, 5.0);
      x_sum += f * Fc;
      y_sum += f;
    }
  }
  const double cell = (1.0 / nx) * (kPi / nphi) * 2.0;
  return {x_sum * cell, y_sum * cell};
}

double V_Kelemen_UnityMobile(double LoH, double perceptualRoughness) {
  return LoH * LoH * (1.0 - perceptualRoughness) + perceptualRoughness * perceptualRoughness;
}

double SpotLightLumensToCandela(double lumens, double cosOuter) {
  return lumens / std::max(2.0 * kPi * (1.0 - cosOuter), 1e-6);
}

double PointLightLumensToCandela(double lumens) { return lumens / (4.0 * kPi); }

double DistanceAttenuation_UE4(double distanceSquared, double inverseRangeSquared) {
  return DistanceWindow(distanceSquared, inverseRangeSquared) / (distanceSquared + 1.0);
}

double DistanceAttenuation_InverseSquare(double distanceSquared) { return 1.0 / std::max(distanceSquared, 1e-4); }

double RoughnessToSpecularPower(double perceptualRoughness) {
  double m = perceptualRoughness * perceptualRoughness;
  return std::max(2.0 / std::max(1e-4, m * m) - 2.0, 1e-4);
}

double SampleSH9(const std::array<double, 9>& sh, Vec3 n) {
  double r = sh[0] + sh[1] * n.y + sh[2] * n.z + sh[3] * n.x + sh[4] * (n.x * n.y) + sh[5] * (n.y * n.z) +
             sh[6] * (3.0 * n.z * n.z - 1.0) + sh[7] * (n.x * n.z) + sh[8] * (n.x * n.x - n.y * n.y);
  return std::max(r, 0.0);
}

double AlbedoAtAlphaOne(double mu) { return 1.0 - mu * std::log(1.0 + 1.0 / mu); }

double AverageSchlickFresnel(double f0) { return (1.0 + 20.0 * f0) / 21.0; }

// The shaders' NoV floor (MIN_N_DOT_V in shaderlib/Common.hlsl): the table's NoV = 0 column holds NoV = 1e-4.
constexpr double kDfgMinNoV = 1e-4;

std::array<double, 2> DfgTableCoordinates(double NoV, double perceptualRoughness) {
  double row = std::clamp((perceptualRoughness - kDfgMinPerceptualRoughness) / (1.0 - kDfgMinPerceptualRoughness), 0.0, 1.0);
  return {std::cbrt(std::clamp(NoV, 0.0, 1.0)), std::sqrt(row)};
}
double DfgColumnNoV(double column) { return column * column * column; }
double DfgRowPerceptualRoughness(double row) {
  return kDfgMinPerceptualRoughness + (1.0 - kDfgMinPerceptualRoughness) * row * row;
}

DfgTable make_dfg_table(int width, int height, uint32_t samples) {
  DfgTable table{width, height, std::vector<float>(static_cast<size_t>(width) * height * 2)};
  for (int j = 0; j < height; ++j)
    for (int i = 0; i < width; ++i) {
      auto dfg = DFG(std::max(DfgColumnNoV(double(i) / (width - 1)), kDfgMinNoV),
                     DfgRowPerceptualRoughness(double(j) / (height - 1)), samples);
      table.rg[(static_cast<size_t>(j) * width + i) * 2] = static_cast<float>(dfg[0]);
      table.rg[(static_cast<size_t>(j) * width + i) * 2 + 1] = static_cast<float>(dfg[1]);
    }
  return table;
}

std::array<double, 2> DfgTable::sample(double NoV, double perceptualRoughness) const {
  auto coordinates = DfgTableCoordinates(NoV, perceptualRoughness);
  double x = coordinates[0] * (width - 1);
  double y = coordinates[1] * (height - 1);
  int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  int x1 = std::min(x0 + 1, width - 1), y1 = std::min(y0 + 1, height - 1);
  double fx = x - x0, fy = y - y0;
  std::array<double, 2> out{};
  for (int c = 0; c < 2; ++c) {
    auto at = [&](int xi, int yi) { return static_cast<double>(rg[(static_cast<size_t>(yi) * width + xi) * 2 + c]); };
    out[c] = (at(x0, y0) * (1 - fx) + at(x1, y0) * fx) * (1 - fy) + (at(x0, y1) * (1 - fx) + at(x1, y1) * fx) * fy;
  }
  return out;
}

std::string encode_dfg_table(const DfgTable& table, uint32_t samples) {
  std::string bytes = "KDFG";
  auto put = [&](uint32_t v) { bytes.append(reinterpret_cast<const char*>(&v), 4); };
  put(kDfgVersion);
  put(static_cast<uint32_t>(table.width));
  put(static_cast<uint32_t>(table.height));
  put(samples);
  bytes.append(reinterpret_cast<const char*>(table.rg.data()), table.rg.size() * sizeof(float));
  return bytes;
}

DfgTable decode_dfg_table(const std::string& bytes) {
  if (bytes.size() < 20 || bytes.compare(0, 4, "KDFG") != 0) render::fail(DiagId::GoldenData, {}, "not a KDFG table");
  uint32_t header[4];
  std::memcpy(header, bytes.data() + 4, 16);
  if (header[0] != kDfgVersion) render::fail(DiagId::GoldenData, {}, "unsupported KDFG version (regenerate with kiln-reference dfg)");
  DfgTable table{static_cast<int>(header[1]), static_cast<int>(header[2]), {}};
  size_t count = static_cast<size_t>(table.width) * table.height * 2;
  if (bytes.size() != 20 + count * sizeof(float)) render::fail(DiagId::GoldenData, {}, "KDFG table has the wrong size");
  table.rg.resize(count);
  std::memcpy(table.rg.data(), bytes.data() + 20, count * sizeof(float));
  return table;
}

}  // namespace kiln::reference
