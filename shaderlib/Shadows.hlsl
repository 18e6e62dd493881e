// kiln shaderlib: Shadows.hlsl — shadow maps with hardware depth comparison, PCF, cascades, biases.
#ifndef KILN_SHADOWS_INCLUDED
#define KILN_SHADOWS_INCLUDED

#include "Common.hlsl"

// One hardware-compared tap (bilinear PCF on hardware that filters comparisons). Coordinates outside the
// map, or beyond the far plane, are lit: nothing was rendered there to cast a shadow.
float SampleShadowTap(Texture2D shadowMap, SamplerComparisonState compare, float3 shadowCoord)
{
    if (any(shadowCoord.xy < 0.0) || any(shadowCoord.xy > 1.0) || shadowCoord.z > 1.0 || shadowCoord.z < 0.0)
        return 1.0;
    return shadowMap.SampleCmpLevelZero(compare, shadowCoord.xy, shadowCoord.z);
}

// Soft shadows: a 3x3 tent of compared taps, one texel apart.
float SampleShadowPCF3x3(Texture2D shadowMap, SamplerComparisonState compare, float3 shadowCoord, float texel)
{
    float sum = 0.0;
    [unroll] for (int y = -1; y <= 1; ++y)
    {
        [unroll] for (int x = -1; x <= 1; ++x)
        {
            float weight = (x == 0 ? 2.0 : 1.0) * (y == 0 ? 2.0 : 1.0);  // tent: 1 2 1 per axis
            sum += weight * SampleShadowTap(shadowMap, compare, shadowCoord + float3(x * texel, y * texel, 0.0));
        }
    }
    return sum / 16.0;
}

float SampleShadow(Texture2D shadowMap, SamplerComparisonState compare, float3 shadowCoord, float texel)
{
#if defined(KILN_FOLDED__SHADOWS_SOFT)  // a bool, not a macro: one module for both (docs/keywords.md)
    if (_SHADOWS_SOFT)
        return SampleShadowPCF3x3(shadowMap, compare, shadowCoord, texel);
    return SampleShadowTap(shadowMap, compare, shadowCoord);
#elif defined(_SHADOWS_SOFT)
    return SampleShadowPCF3x3(shadowMap, compare, shadowCoord, texel);
#else
    return SampleShadowTap(shadowMap, compare, shadowCoord);
#endif
}

// Unity's ComputeCascadeIndex: the first split sphere containing the point. Past the last one: no cascade.
int ComputeCascadeIndex(float3 positionWS, float4 splitSpheres[KILN_MAX_CASCADES], int cascadeCount)
{
    [unroll] for (int i = 0; i < KILN_MAX_CASCADES; ++i)
    {
        float3 fromCenter = positionWS - splitSpheres[i].xyz;
        if (i < cascadeCount && dot(fromCenter, fromCenter) <= splitSpheres[i].w)
            return i;
    }
    return -1;
}

// Receiver-side bias: moves the compared depth towards the light by a constant (in shadow map depth units).
float3 ApplyReceiverDepthBias(float3 shadowCoord, float depthBias)
{
    return float3(shadowCoord.xy, shadowCoord.z - depthBias);
}

// Caster-side bias (ShadowCaster pass): push away from the light by the depth bias and against the normal
// by the normal bias, scaled by the sine of the angle so that grazing surfaces get more (Unity's
// ApplyShadowBias, whose callers pass both biases negated). Pushing towards the light instead puts every
// lit receiver behind its own caster: acne everywhere (kiln test's unoccluded-light check caught it).
float3 ApplyShadowBias(float3 positionWS, float3 normalWS, float3 lightDirectionWS, float depthBias, float normalBias)
{
    float invNoL = 1.0 - saturate(dot(lightDirectionWS, normalWS));
    float scale = invNoL * normalBias;
    positionWS = lightDirectionWS * -depthBias + positionWS;
    positionWS = normalWS * -scale + positionWS;
    return positionWS;
}

#endif // KILN_SHADOWS_INCLUDED
// SPDX-License-Identifier: Apache-2.0
