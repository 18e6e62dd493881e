// SPDX-License-Identifier: Apache-2.0
// kiln's CPU reference: the shader library's physics in double precision, under the same names as the
// HLSL (shaderlib/), plus a Monte-Carlo integrator that produces ground truth (the DFG table the shaders
// sample, directional albedo, white-furnace energy).
//
// Accuracy notes: the terms are exact formulas evaluated in double (relative error ~1e-15). The
// integrators are deterministic (Hammersley points): GGX importance sampling has error roughly
// proportional to 1/sqrt(N) at low roughness and far smaller at high roughness; brute-force midpoint
// quadrature converges as 1/N^2 on smooth integrands and is used to check the sampler.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace kiln::reference {

inline constexpr double kPi = 3.14159265358979323846;

struct Vec3 {
  double x = 0, y = 0, z = 0;
};
inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator*(Vec3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
double dot(Vec3 a, Vec3 b);
Vec3 normalize(Vec3 v);

// Conventions as in shaderlib/Common.hlsl.
inline constexpr double kMinPerceptualRoughness = 0.045;  // fp32 shaders clamp here
double PerceptualRoughnessToAlpha(double perceptualRoughness, double minimum = kMinPerceptualRoughness);
double ComputeF0(double baseColor, double metallic, double reflectance);

// BRDF terms (shaderlib/BRDF.hlsl).
double D_GGX(double NoH, double a);
double D_GGX_Anisotropic(double NoH, double ToH, double BoH, double at, double ab);
double V_SmithGGXCorrelated(double NoV, double NoL, double a);
double V_SmithGGXCorrelated_Fast(double NoV, double NoL, double a);
double V_SmithGGX_Separable(double NoV, double NoL, double a);
double V_SmithGGXCorrelated_Anisotropic(double at, double ab, double ToV, double BoV, double ToL, double BoL, double NoV,
                                        double NoL);
double F_Schlick(double f0, double f90, double VoH);
double Fd_Lambert();
double Fd_Burley(double NoV, double NoL, double LoH, double perceptualRoughness);
double Fd_RenormalizedBurley(double NoV, double NoL, double LoH, double perceptualRoughness);

// IBL (shaderlib/IBL.hlsl).
std::array<double, 2> EnvBRDFApprox(double perceptualRoughness, double NoV);  // scale, bias: E = f0 * x + y
double EnergyCompensation(double dfgY, double f0);

// Lights (shaderlib/Lights.hlsl).
double DistanceWindow(double distanceSquared, double inverseRangeSquared);
double DistanceAttenuation(double distanceSquared, double inverseRangeSquared);
double SpotAttenuation(double cosTheta, double cosInner, double cosOuter);
std::array<double, 3> ColorTemperatureToLinearRGB(double kelvin);

// Tone mapping (shaderlib/Tonemap.hlsl).
std::array<double, 3> ACESFitted(std::array<double, 3> color);

// Fog (shaderlib/Fog.hlsl; Unity's multi_compile_fog): the factor that keeps the surface's color, 1 = no fog, from
// the view depth: linear between the start and end planes (FOG_LINEAR), exp(-density d) (FOG_EXP),
// exp(-(density d)^2) (FOG_EXP2); MixFog blends towards the fog color by 1 - factor.
double FogFactorLinear(double depth, double start, double end);
double FogFactorExp(double depth, double density);
double FogFactorExp2(double depth, double density);
double MixFog(double color, double fog_color, double factor);

// Integrators. The view vector is in the x-z plane: V = (sqrt(1 - NoV^2), 0, NoV), N = +z.
std::array<double, 2> hammersley(uint32_t i, uint32_t count);

// Filament's DFG terms at (NoV, perceptual roughness): x = ∫ V·Fc·NoL, y = ∫ V·NoL (V = D·Vis·4·VoH/NoH
// folded in), by GGX importance sampling with `samples` Hammersley points.
std::array<double, 2> DFG(double NoV, double perceptualRoughness, uint32_t samples);

// Directional albedo of single-scattering GGX (F = Schlick with f0, f90 = 1), by importance sampling.
double SpecularAlbedo(double NoV, double alpha, double f0, uint32_t samples);
// The same by brute-force midpoint quadrature over the hemisphere of L (n x n cells): the check.
double SpecularAlbedoQuadrature(double NoV, double alpha, double f0, int n);

// The DFG terms again, by a method that shares nothing with DFG(): a deterministic midpoint product rule over
// the half-vector hemisphere instead of Hammersley GGX importance sampling, with Smith's Lambda form of the
// height-correlated masking (G2 = 1 / (1 + Lambda(V) + Lambda(L))) instead of V_SmithGGXCorrelated, and no
// D_GGX call: the polar angle is mapped by tan(theta_h) = alpha tan(pi x / 2), under which D(h) dω_h is the
// smooth weight s / (2 cos(theta_h) (1 + s^2)) dx dφ (s = tan(pi x / 2)), so narrow lobes are resolved without
// sampling them. Checked against the closed form at alpha = 1 (tests/unit/reference_test.cpp). Accuracy:
// about 1e-5 away from grazing; at NoV <= 0.01 the visibility cut-off converges as about 1/n^1.5 (5e-4 at
// nx = 512, 3e-5 at nx = 2048, measured at roughness 0.3). Takes alpha, unclamped.
std::array<double, 2> DFGQuadrature(double NoV, double alpha, int nx, int nphi);

// Unity's mobile BRDF visibility term as the shader returns it: 1 / V = LoH^2 (1 - r) + r^2 (BRDF.hlsl).
double V_Kelemen_UnityMobile(double LoH, double perceptualRoughness);
double SpotLightLumensToCandela(double lumens, double cosOuter);
double PointLightLumensToCandela(double lumens);
double DistanceAttenuation_UE4(double distanceSquared, double inverseRangeSquared);
double DistanceAttenuation_InverseSquare(double distanceSquared);
double RoughnessToSpecularPower(double perceptualRoughness);  // Unity's Blinn-Phong exponent (BRDF.hlsl)
// L2 spherical harmonics as SampleSH9 evaluates them (bare polynomials, coefficients pre-convolved), clamped at 0.
double SampleSH9(const std::array<double, 9>& sh, Vec3 n);

// Closed forms used as oracles.
double AlbedoAtAlphaOne(double NoV);          // 1 - mu ln(1 + 1/mu): GGX at alpha = 1, F = 1
double AverageSchlickFresnel(double f0);     // (1 + 20 f0) / 21

// The DFG table as shipped to shaders: width x height texels; texel (i, j) at the table coordinates
// (i / (width - 1), j / (height - 1)), i.e. NoV = (i / (width - 1))^3 (floored at 1e-4 as the shaders floor it)
// and perceptual roughness = 0.045 + (1 - 0.045) (j / (height - 1))^2. The coordinates are not linear because a
// smooth lobe's albedo dips between NoV = 1e-4 and 0.016 and the dip moves with alpha, which a table linear in
// NoV and roughness cannot follow (issue 23; shaderlib/IBL.hlsl says more). Rows start at the fp32 roughness
// floor: the table is looked up at the clamped roughness. The outer texels sit on the edges of the domain, so
// bilinear filtering never extrapolates (a texel-centred table loses 3% of the white furnace at roughness 1,
// measured in bench/REPORT.md); shaders map a coordinate c to (c (n - 1) + 0.5) / n. rg interleaved,
// row-major, rows by roughness.
inline constexpr double kDfgMinPerceptualRoughness = 0.045;
std::array<double, 2> DfgTableCoordinates(double NoV, double perceptualRoughness);  // as shaderlib/IBL.hlsl
double DfgColumnNoV(double column);                // inverse of the column coordinate
double DfgRowPerceptualRoughness(double row);      // inverse of the row coordinate
struct DfgTable {
  int width = 0;
  int height = 0;
  std::vector<float> rg;
  // Bilinear, clamped to the edges; perceptualRoughness is the clamped one, as the shaders pass it.
  std::array<double, 2> sample(double NoV, double perceptualRoughness) const;
};
DfgTable make_dfg_table(int width, int height, uint32_t samples);
// Binary file: "KDFG", u32 version 3 (the coordinates above; version 2 was linear in NoV and roughness, version 1
// texel-centred),
// u32 width, u32 height, u32 samples, then float32 rg (little-endian).
inline constexpr uint32_t kDfgVersion = 3;
std::string encode_dfg_table(const DfgTable& table, uint32_t samples);
DfgTable decode_dfg_table(const std::string& bytes);

}  // namespace kiln::reference
