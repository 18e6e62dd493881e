// kiln shaderlib: Common.hlsl
//
// Conventions (every file of the library follows them):
// - Space suffixes: OS object, WS world, VS view, CS clip, TS tangent (positionWS, normalOS).
// - Directions point away from the shaded point: L to the light, V to the eye; dot products are
//   named by their vectors (NoV, NoL, NoH, LoH, VoH, ToH, BoH).
// - Materials expose perceptual roughness; alpha = perceptualRoughness^2 is formed, and clamped,
//   only when a BRDF is evaluated (seed 000; Filament), never at material fetch.
// - Functions are stateless: everything they read is a parameter; literals are written 1.0.
// - `real` is float, or a true 16-bit float (`half` with 16-bit types enabled) under _HALF_PRECISION.
//   glslang 12 does not accept `float16_t` as a type name in HLSL; `half` is the spelling that works.
// - Every clamp and epsilon says why, with its number.
#ifndef KILN_COMMON_INCLUDED
#define KILN_COMMON_INCLUDED

#define PI      3.14159265358979323846
#define INV_PI  0.31830988618379067154

// Largest finite fp16 value; Filament's saturateMediump clamps to it so that fp16 never reaches Inf.
#define HALF_MAX 65504.0

#if defined(_HALF_PRECISION)
typedef half  real;
typedef half2 real2;
typedef half3 real3;
typedef half4 real4;
// fp16: 0.089^4 = 6.27e-5 stays above the smallest normal fp16 (6.10e-5), so 1/alpha^2 is finite (seed 000).
#define MIN_PERCEPTUAL_ROUGHNESS 0.089
// 0.5 / (GGXV + GGXL) <= HALF_MAX needs a denominator of at least 0.5 / 65504 = 7.63e-6.
#define MIN_VISIBILITY_DENOMINATOR 7.63e-6
#define REAL_MAX HALF_MAX
#else
typedef float  real;
typedef float2 real2;
typedef float3 real3;
typedef float4 real4;
// fp32: Filament's 0.045 keeps a visible highlight at roughness 0 and alpha^2 = 4.1e-6 well above FLT_MIN.
#define MIN_PERCEPTUAL_ROUGHNESS 0.045
// Only prevents 0/0 at NoV = NoL = 0; the smallest real denominator is ~2e-7 at the NoV floor.
#define MIN_VISIBILITY_DENOMINATOR 1e-30
#define REAL_MAX 3.402823e38
#endif

// Filament clamps NoV to 1e-4: at exactly 0 the visibility term divides by zero and the view is edge-on.
#define MIN_N_DOT_V 1e-4

// Filament's saturateMediump: keeps fp16 intermediates finite; the identity in fp32 (where 65504 is a
// legitimate value: D_GGX alone reaches 1 / (pi 0.045^4) = 7.8e4).
// glslang 12 promotes HLSL intrinsics on half to float and will not narrow implicitly: intrinsics on real
// values are cast back to real explicitly throughout the library (and run in fp32 inside glslang's output).
#if defined(_HALF_PRECISION)
real saturateMediump(real x) { return (real)min(x, (real)HALF_MAX); }
real3 saturateMediump3(real3 x) { return (real3)min(x, (real3)HALF_MAX); }
#else
real saturateMediump(real x) { return x; }
real3 saturateMediump3(real3 x) { return x; }
#endif

// normalize() of a zero vector is NaN; this returns the fallback instead (zero-length normals, L at the light).
float3 SafeNormalize(float3 v, float3 fallback)
{
    float lengthSquared = dot(v, v);
    // 1e-20: squared lengths below it are treated as zero; rsqrt(1e-20) = 1e10 is still finite.
    return lengthSquared > 1e-20 ? v * rsqrt(lengthSquared) : fallback;
}

float3 SafeNormalize(float3 v) { return SafeNormalize(v, float3(0.0, 0.0, 1.0)); }

real Pow5(real x)
{
    real x2 = x * x;
    return x2 * x2 * x;
}

real Square(real x) { return x * x; }

// alpha = perceptualRoughness^2, clamped at evaluation time (see MIN_PERCEPTUAL_ROUGHNESS).
real PerceptualRoughnessToAlpha(real perceptualRoughness)
{
    real clamped = (real)clamp(perceptualRoughness, (real)MIN_PERCEPTUAL_ROUGHNESS, (real)1.0);
    return clamped * clamped;
}

real ClampedPerceptualRoughness(real perceptualRoughness)
{
    return (real)clamp(perceptualRoughness, (real)MIN_PERCEPTUAL_ROUGHNESS, (real)1.0);
}

// Filament / Frostbite reflectance remapping: dielectric F0 = 0.16 reflectance^2 (0.5 -> 0.04), metals use base color.
real3 ComputeF0(real3 baseColor, real metallic, real reflectance)
{
    real dielectric = (real)0.16 * reflectance * reflectance;
    return (real3)lerp((real3)dielectric, baseColor, metallic);
}

real3 ComputeDiffuseColor(real3 baseColor, real metallic)
{
    return baseColor * ((real)1.0 - metallic);
}

#endif // KILN_COMMON_INCLUDED
// SPDX-License-Identifier: Apache-2.0
