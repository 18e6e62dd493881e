// kiln shaderlib: BRDF.hlsl — the BRDF terms, one function each, each citing its source.
// Conventions: see Common.hlsl. `a` is alpha (perceptualRoughness^2, already clamped).
// Term functions return the term alone; NoL is applied by the shading model (Shading.hlsl).
#ifndef KILN_BRDF_INCLUDED
#define KILN_BRDF_INCLUDED

#include "Common.hlsl"

//------------------------------------------------------------------------------
// Normal distribution functions
//------------------------------------------------------------------------------

// Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces" (GGX / Trowbridge-Reitz).
// oneMinusNoHSquared is passed in: computed as |n x h|^2 it keeps precision in fp16 where 1 - NoH^2
// cancels catastrophically for NoH near 1 (Filament, "mediump-safe" GGX).
real D_GGX(real NoH, real a, real oneMinusNoHSquared)
{
    real aNoH = NoH * a;
    // Denominator >= a^2 * NoH^2 + (1 - NoH^2) > 0 for a >= 0.045^2: never zero after the roughness clamp.
    real k = a / (oneMinusNoHSquared + aNoH * aNoH);
    return saturateMediump(k * k * (real)INV_PI);
}

// Burley 2012, "Physically-Based Shading at Disney" (anisotropic GGX); Filament's formulation.
// Evaluated in fp32 in every variant, cosines included, as Filament does (highp): with at * ab down to 0.089^4
// the squared terms leave the fp16 range, and a lobe this narrow turns NoH's fp16 rounding (5e-4 near 1) into
// a 55x error (both measured by the stress gate).
real D_GGX_Anisotropic(float NoH, float ToH, float BoH, real at, real ab)
{
    float a2 = (float)at * (float)ab;
    float3 d = float3((float)ab * ToH, (float)at * BoH, a2 * NoH);
    float d2 = dot(d, d);
    // d2 >= (a2 NoH)^2 > 0 except at NoH = 0, where the lobe is 0: the 1e-30 floor only prevents 0/0.
    float b2 = a2 / max(d2, 1e-30);
    return (real)min(a2 * b2 * b2 * INV_PI, REAL_MAX);
}

// Blinn-Phong NDF with Unity's normalization, for the mobile BRDF (seed 003; Unity BRDF2_Unity_PBS).
real RoughnessToSpecularPower(real perceptualRoughness)
{
    real m = perceptualRoughness * perceptualRoughness;
    // Unity: sq = max(1e-4, m^2) bounds the exponent at 2/1e-4 - 2 = 19998.
    real sq = (real)max((real)1e-4, m * m);
    return (real)max((real)2.0 / sq - (real)2.0, (real)1e-4);
}

//------------------------------------------------------------------------------
// Visibility: V = G / (4 NoL NoV)
//------------------------------------------------------------------------------

// Heitz 2014, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs" (height-correlated Smith GGX).
real V_SmithGGXCorrelated(real NoV, real NoL, real a)
{
    real a2 = a * a;
    real GGXV = NoL * (real)sqrt(NoV * NoV * ((real)1.0 - a2) + a2);  // argument >= a2 > 0: NoV^2 (1 - a2) >= 0
    real GGXL = NoV * (real)sqrt(NoL * NoL * ((real)1.0 - a2) + a2);  // argument >= a2 > 0, likewise
    return saturateMediump((real)0.5 / (real)max(GGXV + GGXL, (real)MIN_VISIBILITY_DENOMINATOR));
}

// Hammon 2017, "PBR Diffuse Lighting for GGX+Smith Microsurfaces": sqrt-free approximation
// (max pointwise error ~29%, mean 7.5% against the exact form; see ARCHITECTURE.md).
real V_SmithGGXCorrelated_Fast(real NoV, real NoL, real a)
{
    real v = (real)0.5 / (real)max((real)lerp((real)2.0 * NoL * NoV, NoL + NoV, a), (real)MIN_VISIBILITY_DENOMINATOR);
    return saturateMediump(v);
}

// Separable (uncorrelated) Smith GGX, Walter 2007: the classic form, kept for the cost/error study.
real V_SmithGGX_Separable(real NoV, real NoL, real a)
{
    real a2 = a * a;
    real GV = NoV + (real)sqrt(NoV * NoV * ((real)1.0 - a2) + a2);  // argument >= a2 > 0: NoV^2 (1 - a2) >= 0
    real GL = NoL + (real)sqrt(NoL * NoL * ((real)1.0 - a2) + a2);  // argument >= a2 > 0, likewise
    return saturateMediump((real)1.0 / (real)max(GV * GL, (real)MIN_VISIBILITY_DENOMINATOR));
}

// Heitz 2014 anisotropic height-correlated Smith; Filament's formulation (seed 001). fp32 inside, like
// D_GGX_Anisotropic: in fp16 the stress gate measured the denominator collapsing to 0 (V = 65504 for 0.22).
real V_SmithGGXCorrelated_Anisotropic(real at, real ab, float ToV, float BoV, float ToL, float BoL, float NoV, float NoL)
{
    float lambdaV = NoL * length(float3((float)at * ToV, (float)ab * BoV, NoV));
    float lambdaL = NoV * length(float3((float)at * ToL, (float)ab * BoL, NoL));
    return (real)min(0.5 / max(lambdaV + lambdaL, 1e-30), REAL_MAX);
}

// Kelemen and Szirmay-Kalos 2001, as approximated in Unity's mobile BRDF: 1 / (LoH^2 (1 - r) + r^2) (seed 003).
real V_Kelemen_UnityMobile(real LoH, real perceptualRoughness)
{
    real invV = LoH * LoH * ((real)1.0 - perceptualRoughness) + perceptualRoughness * perceptualRoughness;
    return invV;
}

//------------------------------------------------------------------------------
// Fresnel
//------------------------------------------------------------------------------

// Schlick 1994, "An Inexpensive BRDF Model for Physically-based Rendering"; x^5 as a multiply chain.
real3 F_Schlick(real3 f0, real f90, real VoH)
{
    real f = Pow5((real)1.0 - VoH);
    return f0 + (f90 - f0) * f;
}

real F_Schlick(real f0, real f90, real VoH)
{
    return f0 + (f90 - f0) * Pow5((real)1.0 - VoH);
}

// Same term with pow(): kept for the cost study (pow is exp2(log2) on most GPUs). 1 - VoH >= 0 is
// required by pow's domain; saturate keeps rounding from producing a tiny negative base.
real3 F_Schlick_Pow(real3 f0, real f90, real VoH)
{
    return f0 + (f90 - f0) * (real)pow((real)saturate((real)1.0 - VoH), (real)5.0);
}

//------------------------------------------------------------------------------
// Diffuse
//------------------------------------------------------------------------------

// Lambert 1760: the constant 1/pi.
real Fd_Lambert()
{
    return (real)INV_PI;
}

// Burley 2012, "Physically-Based Shading at Disney". Takes perceptual roughness, as Disney's model does.
real Fd_Burley(real NoV, real NoL, real LoH, real perceptualRoughness)
{
    real f90 = (real)0.5 + (real)2.0 * perceptualRoughness * LoH * LoH;
    real lightScatter = F_Schlick((real)1.0, f90, NoL);
    real viewScatter = F_Schlick((real)1.0, f90, NoV);
    return lightScatter * viewScatter * (real)INV_PI;
}

// Lagarde and de Rousiers 2014, "Moving Frostbite to PBR": Burley renormalized so that diffuse + specular
// do not exceed 1 (energy factor 1/1.51 at roughness 1). Perceptual roughness, as in seed 000.
real Fd_RenormalizedBurley(real NoV, real NoL, real LoH, real perceptualRoughness)
{
    real energyBias = (real)lerp((real)0.0, (real)0.5, perceptualRoughness);
    real energyFactor = (real)lerp((real)1.0, (real)(1.0 / 1.51), perceptualRoughness);
    real fd90 = energyBias + (real)2.0 * LoH * LoH * perceptualRoughness;
    real lightScatter = F_Schlick((real)1.0, fd90, NoL);
    real viewScatter = F_Schlick((real)1.0, fd90, NoV);
    return lightScatter * viewScatter * energyFactor * (real)INV_PI;
}

#endif // KILN_BRDF_INCLUDED
// SPDX-License-Identifier: Apache-2.0
