// kiln shaderlib: Shading.hlsl — shading models: the standard metallic/roughness Cook-Torrance model,
// the anisotropic (silk) model and Unity's mobile BRDF, behind one dispatch.
//
// Configuration block: keywords choose implementations here and only here (Filament's brdf.fs style);
// the functions below and in BRDF.hlsl never test a keyword.
//   _DIFFUSE_BURLEY   diffuse = Frostbite's renormalized Burley, else Lambert
//   _ANISOTROPY       specular = anisotropic GGX + anisotropic correlated Smith (seed 001)
//   _MOBILE_BRDF      Unity's mobile BRDF (Blinn-Phong + Kelemen, seed 003) instead of GGX
//   _ENV_BRDF_APPROX  Karis's analytic environment BRDF instead of the DFG table
//   _MULTISCATTER     Kulla-Conty energy compensation (only with the DFG table)
//   _SPECULARHIGHLIGHTS_OFF, _ENVIRONMENTREFLECTIONS_OFF  Unity's material switches (seed 003)
#ifndef KILN_SHADING_INCLUDED
#define KILN_SHADING_INCLUDED

#include "BRDF.hlsl"
#include "IBL.hlsl"

#if defined(_DIFFUSE_BURLEY)
#define KILN_DIFFUSE_MODEL_BURLEY 1
#endif
#if defined(_MOBILE_BRDF)
#define KILN_SPECULAR_MODEL_MOBILE 1
#elif defined(_ANISOTROPY)
#define KILN_SPECULAR_MODEL_ANISOTROPIC 1
#endif
#if defined(_ENV_BRDF_APPROX) || defined(_MOBILE_BRDF)
#define KILN_ENV_BRDF_APPROX 1
#endif
#if defined(_MULTISCATTER) && !defined(KILN_ENV_BRDF_APPROX)
#define KILN_MULTISCATTER 1
#endif

// What a material gives the lighting, before any light is known.
struct SurfaceData
{
    real3 baseColor;
    real metallic;
    real perceptualRoughness;  // as authored; clamped only at evaluation
    real reflectance;
    real anisotropy;
    float3 normalWS;
    float3 tangentWS;
    float3 bitangentWS;
    float3 viewWS;             // unit vector towards the eye
};

// Per-pixel quantities derived once and shared by every light.
struct ShadingData
{
    real3 diffuseColor;
    real3 f0;
    real perceptualRoughness;  // clamped
    real alpha;                // clamped perceptualRoughness^2
    real at;                   // anisotropic alpha along the tangent
    real ab;                   // ... and the bitangent
    real NoV;
    real3 specularAlbedo;      // E: directional albedo of the specular lobe for this f0 (DFG or approx)
    real3 energyCompensation;  // 1 without _MULTISCATTER
    float3 N;
    float3 T;
    float3 B;
    float3 V;
};

ShadingData PrepareShading(SurfaceData surface, real2 dfg)
{
    ShadingData s;
    s.diffuseColor = ComputeDiffuseColor(surface.baseColor, surface.metallic);
    s.f0 = ComputeF0(surface.baseColor, surface.metallic, surface.reflectance);
    s.perceptualRoughness = ClampedPerceptualRoughness(surface.perceptualRoughness);
    s.alpha = s.perceptualRoughness * s.perceptualRoughness;
    // Filament: at/ab floored at the same minimum alpha as the isotropic lobe.
    real minAlpha = (real)(MIN_PERCEPTUAL_ROUGHNESS * MIN_PERCEPTUAL_ROUGHNESS);
    s.at = (real)max(s.alpha * ((real)1.0 + surface.anisotropy), minAlpha);
    s.ab = (real)max(s.alpha * ((real)1.0 - surface.anisotropy), minAlpha);
    s.N = surface.normalWS;
    s.T = surface.tangentWS;
    s.B = surface.bitangentWS;
    s.V = surface.viewWS;
    s.NoV = (real)max(dot(s.N, s.V), MIN_N_DOT_V);
#if defined(KILN_ENV_BRDF_APPROX)
    s.specularAlbedo = EnvBRDFApprox(s.f0, s.perceptualRoughness, s.NoV);
#else
    s.specularAlbedo = SpecularDFG(dfg, s.f0);
#endif
#if defined(KILN_MULTISCATTER) && defined(KILN_FOLDED__MULTISCATTER)  // a bool (docs/keywords.md)
    s.energyCompensation = (real3)1.0;
    if (_MULTISCATTER)
        s.energyCompensation = EnergyCompensation(dfg, s.f0);
#elif defined(KILN_MULTISCATTER)
    s.energyCompensation = EnergyCompensation(dfg, s.f0);
#else
    s.energyCompensation = (real3)1.0;
#endif
    return s;
}

real DiffuseLobe(ShadingData s, real NoL, real LoH)
{
#if defined(KILN_DIFFUSE_MODEL_BURLEY)
    return Fd_RenormalizedBurley(s.NoV, NoL, LoH, s.perceptualRoughness);
#else
    return Fd_Lambert();
#endif
}

// D * V for the configured specular model, as fp32: in fp16 the product overflows where F and NoL would
// bring it back in range (D = 5e3 and V = 50 at roughness 0.1, NoV at its floor; the stress gate found it).
float SpecularDV(ShadingData s, float3 L, float3 H, real NoL, real NoH)
{
#if defined(KILN_SPECULAR_MODEL_ANISOTROPIC)
    // Cosines in fp32 (see D_GGX_Anisotropic).
    float NoVFull = max(dot(s.N, s.V), MIN_N_DOT_V);
    float NoLFull = saturate(dot(s.N, L));
    return (float)D_GGX_Anisotropic(saturate(dot(s.N, H)), dot(s.T, H), dot(s.B, H), s.at, s.ab) *
           (float)V_SmithGGXCorrelated_Anisotropic(s.at, s.ab, dot(s.T, s.V), dot(s.B, s.V), dot(s.T, L), dot(s.B, L),
                                                   NoVFull, NoLFull);
#else
    float3 NxH = cross(s.N, H);
    real oneMinusNoHSquared = (real)dot(NxH, NxH);
    return (float)D_GGX(NoH, s.alpha, oneMinusNoHSquared) * (float)V_SmithGGXCorrelated(s.NoV, NoL, s.alpha);
#endif
}

// Reflected radiance per unit illuminance from L: BRDF * NoL (NoL inside, as seed 000 does).
// Returned as fp32 in every variant: BRDF * NoL per unit illuminance is not bounded by the fp16 range. A smooth
// lobe seen at grazing angles peaks above it (roughness 0.089, NoV = NoL = 1e-3: D * V * NoL = 1.6e5), and
// clamping D * V * F at 65504 before NoL scaled it down lost up to 69% of the directional albedo (issue 23).
// So the specular product and NoL are multiplied in fp32 and nothing is clamped: AccumulateLight applies the
// light's illuminance in fp32 too, and the Forward pass sums lights in fp32.
float3 DirectBRDF(ShadingData s, float3 L)
{
    // NoL in fp32 for the fp32 product below; the real copy feeds the fp16 terms.
    float NoLFull = saturate(dot(s.N, L));
    real NoL = (real)NoLFull;
    if (NoL <= (real)0.0)
        return (float3)0.0;
    // L = -V has no half vector; any unit vector works there because NoL or NoV is then ~0.
    float3 H = SafeNormalize(L + s.V, s.N);
    real NoH = (real)saturate(dot(s.N, H));
    real LoH = (real)saturate(dot(L, H));
#if defined(KILN_SPECULAR_MODEL_MOBILE)
    // Unity BRDF2_Unity_PBS: ((n + 1) NoH^n) / (8 invV LoH + 1e-4), with Unity's pi-scaled light units
    // converted back (divided by pi) so that lights stay in lux and candela.
    real n = RoughnessToSpecularPower(s.perceptualRoughness);
    real invV = V_Kelemen_UnityMobile(LoH, s.perceptualRoughness);
    // pow(0, n) is 0 for n > 0; max keeps the base inside pow's domain.
    real specular = (n + (real)1.0) * (real)pow((real)max(NoH, (real)1e-4), n) / ((real)8.0 * invV * LoH + (real)1e-4);
    specular = saturateMediump(specular);
#if defined(_SPECULARHIGHLIGHTS_OFF)
    specular = (real)0.0;
#endif
    return (float3)(s.diffuseColor + specular * s.f0) * (INV_PI * NoLFull);
#else
    real3 F = F_Schlick(s.f0, (real)1.0, LoH);
    real3 diffuse = s.diffuseColor * DiffuseLobe(s, NoL, LoH) * ((real3)1.0 - F);
#if defined(_SPECULARHIGHLIGHTS_OFF)
    float3 specular = (float3)0.0;
#else
    // D * V (fp32, see SpecularDV) * F * energy compensation, all in fp32: no intermediate clamp.
    float3 specular = SpecularDV(s, L, H, NoL, NoH) * (float3)(F * s.energyCompensation);
#endif
    return ((float3)diffuse + specular) * NoLFull;
#endif
}

// Image-based lighting: diffuse from SH, specular from the prefiltered cube (or a flat color).
// The radiances are narrowed to `real` through a clamp at REAL_MAX (an fp16 cast of a larger value is Inf).
real3 IndirectLighting(ShadingData s, float3 irradianceOverPi, float3 prefilteredRadiance)
{
    real3 irradiance = (real3)min(irradianceOverPi, (float3)REAL_MAX);
    real3 prefiltered = (real3)min(prefilteredRadiance, (float3)REAL_MAX);
    real3 diffuse = saturateMediump3(s.diffuseColor * irradiance * ((real3)1.0 - s.specularAlbedo));
    real3 specular = saturateMediump3(prefiltered * s.specularAlbedo * s.energyCompensation);
    return saturateMediump3(diffuse + specular);
}

#endif // KILN_SHADING_INCLUDED
// SPDX-License-Identifier: Apache-2.0
