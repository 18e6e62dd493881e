// kiln shaderlib: Lighting.hlsl — the lights of a frame: main directional light with cascaded shadows,
// additional point/spot lights (per pixel, per vertex or Forward+ tiles) with shadows, and IBL.
#ifndef KILN_LIGHTING_INCLUDED
#define KILN_LIGHTING_INCLUDED

#include "Input.hlsl"
#include "Lights.hlsl"
#include "Shading.hlsl"
// Feature files are included only by the variants that use them, so that editing one recompiles only those.
#if defined(_MAIN_LIGHT_SHADOWS) || defined(_MAIN_LIGHT_SHADOWS_CASCADE) || defined(_ADDITIONAL_LIGHT_SHADOWS)
#include "Shadows.hlsl"
#endif

struct Light
{
    float3 L;          // unit vector towards the light
    float3 radiance;   // illuminance (lux) arriving at the point: color * intensity * attenuation
    float shadow;      // 1 lit, 0 shadowed
};

// A directional light: `direction` points towards the light (need not be unit length), `illuminance` in lux.
Light DirectionalLight(float3 direction, float3 illuminance)
{
    Light light;
    light.L = SafeNormalize(direction, float3(0.0, 1.0, 0.0));
    light.radiance = illuminance;
    light.shadow = 1.0;
    return light;
}

// A point or spot light (unshadowed): `toLight` goes from the shaded point to the light, `intensity` is
// color * candela, spotDirection.w > 0.5 marks a spot with axis spotDirection.xyz (from the light).
Light PunctualLight(float3 toLight, float3 intensity, float inverseRangeSquared, float4 spotDirection, float2 spotScaleOffset)
{
    float distanceSquared = dot(toLight, toLight);
    Light light;
    // At distance 0 the direction is undefined: pick the normal-independent +Y rather than NaN.
    light.L = SafeNormalize(toLight, float3(0.0, 1.0, 0.0));
    float attenuation = DistanceAttenuation(distanceSquared, inverseRangeSquared);
    if (spotDirection.w > 0.5)
        attenuation *= SpotAttenuation(light.L, spotDirection.xyz, spotScaleOffset);
    light.radiance = intensity * attenuation;
    light.shadow = 1.0;
    return light;
}

#if defined(_MAIN_LIGHT_SHADOWS) || defined(_MAIN_LIGHT_SHADOWS_CASCADE) || defined(_ADDITIONAL_LIGHT_SHADOWS)
// Receiver bias, compared sample (PCF under _SHADOWS_SOFT), then the shadow strength:
// params = (strength, depth bias, texel size, -), as the frame constants store them for both shadow maps.
float ShadowVisibility(Texture2D shadowMap, float3 shadowCoord, float4 params)
{
    float3 coord = ApplyReceiverDepthBias(shadowCoord, params.y);
    float visibility = SampleShadow(shadowMap, sampler_ShadowCompare, coord, params.z);
    return lerp(1.0, visibility, params.x);
}
#endif

float3 MainLightShadowCoord(float3 positionWS, int cascade)
{
    float4 coord = mul(_MainLightWorldToShadow[cascade], float4(positionWS, 1.0));
    return coord.xyz / coord.w;
}

float MainLightShadow(float3 positionWS, float3 vertexShadowCoord)
{
#if defined(_MAIN_LIGHT_SHADOWS) || defined(_MAIN_LIGHT_SHADOWS_CASCADE)
#if defined(_MAIN_LIGHT_SHADOWS_CASCADE)
    int cascade = ComputeCascadeIndex(positionWS, _CascadeSplitSpheres, (int)_MainLightShadowParams.w);
    if (cascade < 0)
        return 1.0;
    float3 coord = MainLightShadowCoord(positionWS, cascade);
#else
    float3 coord = vertexShadowCoord;
#endif
    return ShadowVisibility(_MainLightShadowMap, coord, _MainLightShadowParams);
#else
    return 1.0;
#endif
}

Light GetMainLight(float3 positionWS, float3 vertexShadowCoord)
{
    Light light = DirectionalLight(_MainLightDirectionWS.xyz, _MainLightColor.rgb);
    light.shadow = MainLightShadow(positionWS, vertexShadowCoord);
    return light;
}

// Index of the cube face a direction falls on, in the order +X -X +Y -Y +Z -Z.
uint CubeFaceIndex(float3 direction)
{
    float3 a = abs(direction);
    if (a.x >= a.y && a.x >= a.z)
        return direction.x >= 0.0 ? 0u : 1u;
    if (a.y >= a.z)
        return direction.y >= 0.0 ? 2u : 3u;
    return direction.z >= 0.0 ? 4u : 5u;
}

float AdditionalLightShadow(AdditionalLight data, float3 positionWS)
{
#if defined(_ADDITIONAL_LIGHT_SHADOWS)
    if (data.color.w < 0.0)
        return 1.0;
    uint matrixIndex = (uint)data.color.w;
    if (data.spotDirectionWS.w < 0.5)  // point light: one matrix per cube face
        matrixIndex += CubeFaceIndex(positionWS - data.positionWS.xyz);
    float4 coord = mul(_AdditionalShadowMatrices[matrixIndex], float4(positionWS, 1.0));
    // w > 0 in front of the light; behind it nothing can shadow.
    if (coord.w <= 1e-6)
        return 1.0;
    return ShadowVisibility(_AdditionalLightsShadowMap, coord.xyz / coord.w, _AdditionalShadowParams);
#else
    return 1.0;
#endif
}

Light GetAdditionalLight(uint index, float3 positionWS)
{
    AdditionalLight data = _AdditionalLights[index];
    Light light = PunctualLight(data.positionWS.xyz - positionWS, data.color.rgb, data.positionWS.w, data.spotDirectionWS,
                                data.spotScaleOffset.xy);
    light.shadow = AdditionalLightShadow(data, positionWS);
    return light;
}

// Reflected radiance from one light: BRDF * NoL * illuminance * shadow, in fp32 in every variant. Not narrowed
// to `real`: the Forward pass sums lights in fp32, and a grazing highlight of a smooth surface under a light of
// 1 lux already exceeds 65504 (DirectBRDF), so a clamp here lost up to 10% of the fp16 lobe's energy.
float3 AccumulateLight(ShadingData s, Light light)
{
    return DirectBRDF(s, light.L) * (light.radiance * light.shadow);
}

// Reflected radiance of the per-pixel additional lights (_ADDITIONAL_LIGHTS) at a pixel, summed in fp32: the
// plain loop over every light, or under _FORWARD_PLUS only the lights listed for the pixel's screen tile
// (lights that cannot reach the tile cost nothing). `pixel` is SV_Position.xy.
float3 AdditionalLightsRadiance(ShadingData s, float3 positionWS, float2 pixel)
{
    float3 color = 0.0;
#if defined(_FORWARD_PLUS)
    uint2 tile = (uint2)pixel / max(_LightCounts.y, 1u);
    uint listStart = (tile.y * _LightCounts.z + tile.x) * (uint)KILN_TILE_STRIDE;
    uint count = min(_TileLightIndices[listStart], (uint)KILN_MAX_LIGHTS_PER_TILE);
    for (uint i = 0u; i < count; ++i)
        color += AccumulateLight(s, GetAdditionalLight(_TileLightIndices[listStart + 1u + i], positionWS));
#else
    for (uint i = 0u; i < _LightCounts.x; ++i)
        color += AccumulateLight(s, GetAdditionalLight(i, positionWS));
#endif
    return color;
}

// Per-vertex additional lights (_ADDITIONAL_LIGHTS_VERTEX): Lambert irradiance/pi at the vertex, shadowless,
// for at most KILN_MAX_VERTEX_LIGHTS lights, as URP does.
float3 VertexLighting(float3 positionWS, float3 normalWS)
{
    // fp32 in every variant: it is one sum per vertex, and illuminance routinely exceeds the fp16 range.
    float3 irradiance = 0.0;
    uint count = min(_LightCounts.x, (uint)KILN_MAX_VERTEX_LIGHTS);
    for (uint i = 0u; i < count; ++i)
    {
        Light light = GetAdditionalLight(i, positionWS);
        irradiance += light.radiance * saturate(dot(normalWS, light.L));
    }
    return irradiance * INV_PI;
}

#endif // KILN_LIGHTING_INCLUDED
// SPDX-License-Identifier: Apache-2.0
