// kiln shaderlib: Fog.hlsl — Unity's multi_compile_fog modes: FOG_LINEAR, FOG_EXP, FOG_EXP2.
// The fog coordinate is the view depth (distance along the camera's forward axis, as Unity's fog uses
// depth): linear in the position, so computing it per vertex and interpolating is exact. Factor 1 = no fog.
#ifndef KILN_FOG_INCLUDED
#define KILN_FOG_INCLUDED

#if defined(FOG_LINEAR) || defined(FOG_EXP) || defined(FOG_EXP2)
#define KILN_FOG 1
#endif

float ComputeFogDepth(float3 positionWS, float3 cameraPositionWS, float3 cameraForwardWS)
{
    return max(dot(positionWS - cameraPositionWS, cameraForwardWS), 0.0);
}

float ComputeFogFactor(float distance, float4 fogParams)
{
#if defined(KILN_FOLDED_FOG_LINEAR)
    // The mode is three bools, not macros (docs/keywords.md): one module for every mode, the same formulas.
    if (FOG_LINEAR)
        return saturate((fogParams.z - distance) / max(fogParams.z - fogParams.y, 1e-4));
    if (FOG_EXP)
        return saturate(exp2(-fogParams.x * distance * 1.44269504));
    if (FOG_EXP2)
    {
        float x = fogParams.x * distance;
        return saturate(exp2(-x * x * 1.44269504));
    }
    return 1.0;
#elif defined(FOG_LINEAR)
    // end - start floored at 1e-4 so that equal planes give a hard step instead of 0/0.
    return saturate((fogParams.z - distance) / max(fogParams.z - fogParams.y, 1e-4));
#elif defined(FOG_EXP)
    return saturate(exp2(-fogParams.x * distance * 1.44269504));  // exp(-d x) = exp2(-d x / ln 2)
#elif defined(FOG_EXP2)
    float x = fogParams.x * distance;
    return saturate(exp2(-x * x * 1.44269504));
#else
    return 1.0;
#endif
}

float3 MixFog(float3 color, float3 fogColor, float fogFactor)
{
    return lerp(fogColor, color, fogFactor);
}

#endif // KILN_FOG_INCLUDED
// SPDX-License-Identifier: Apache-2.0
