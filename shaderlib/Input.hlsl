// kiln shaderlib: Input.hlsl — every resource the library binds, at fixed, unique bindings in set 0.
// Unique binding numbers across the whole library let the GL outputs use the same numbers, and let
// kiln verify that every variant of a pass agrees on the layout. Never bind a resource inside #if:
// declare it always; the optimizer removes what a variant does not read.
#ifndef KILN_INPUT_INCLUDED
#define KILN_INPUT_INCLUDED

#define KILN_MAX_CASCADES 4
#define KILN_MAX_VERTEX_LIGHTS 8
// Forward+ tile list layout: [count, index0, ..., index(KILN_MAX_LIGHTS_PER_TILE - 1)] per tile.
#define KILN_MAX_LIGHTS_PER_TILE 63
#define KILN_TILE_STRIDE (KILN_MAX_LIGHTS_PER_TILE + 1)

[[vk::binding(0, 0)]] cbuffer PerFrame : register(b0)
{
    float4x4 _ViewProjection;
    float4   _CameraPositionWS;           // xyz
    float4   _MainLightDirectionWS;       // xyz: unit vector towards the light
    float4   _MainLightColor;             // rgb: illuminance (lux) times color
    float4x4 _MainLightWorldToShadow[KILN_MAX_CASCADES];  // to [0,1]^2 atlas coordinates and [0,1] depth
    float4   _CascadeSplitSpheres[KILN_MAX_CASCADES];     // xyz center, w radius^2
    float4   _MainLightShadowParams;      // x strength, y receiver depth bias, z 1/shadow map texel, w cascade count
    float4   _AdditionalShadowParams;     // x strength, y receiver depth bias, z 1/atlas texel
    float4   _FogColor;                   // rgb
    float4   _FogParams;                  // x density (exp, exp2), y linear start, z linear end
    float4   _AmbientSH[9];               // L2 irradiance SH, rgb, convolved with the cosine lobe and divided by pi
    float4   _EnvironmentParams;          // x prefiltered cube mip count - 1, y exposure, z IBL intensity
    float4   _GlossyEnvironmentColor;     // rgb: the reflection used under _ENVIRONMENTREFLECTIONS_OFF
    float4   _ProbePositionWS;            // xyz, w > 0: box projection on
    float4   _ProbeBoxMin;
    float4   _ProbeBoxMax;
    uint4    _LightCounts;                // x additional lights, y Forward+ tile size in pixels, z tiles per row
    float4   _CameraForwardWS;            // xyz: unit view direction (fog uses view depth along it)
};

[[vk::binding(1, 0)]] cbuffer PerMaterial : register(b1)
{
    float4 _BaseColor;                    // rgb linear base color, a unused
    float  _Metallic;
    float  _PerceptualRoughness;
    float  _Reflectance;                  // dielectric F0 = 0.16 reflectance^2
    float  _Anisotropy;                   // -1..1, along the tangent (+) or bitangent (-)
};

[[vk::binding(2, 0)]] cbuffer PerObject : register(b2)
{
    float4x4 _ObjectToWorld;
    float4x4 _WorldToObject;              // its transpose transforms normals
};

[[vk::binding(3, 0)]] Texture2D _MainLightShadowMap : register(t3);
[[vk::binding(4, 0)]] SamplerComparisonState sampler_ShadowCompare : register(s4);
[[vk::binding(5, 0)]] Texture2D _AdditionalLightsShadowMap : register(t5);
[[vk::binding(6, 0)]] TextureCube _EnvironmentMap : register(t6);
[[vk::binding(7, 0)]] SamplerState sampler_LinearClamp : register(s7);
[[vk::binding(8, 0)]] Texture2D _DFG : register(t8);  // RG: (integral of V Fc, integral of V), see IBL.hlsl

struct AdditionalLight
{
    float4 positionWS;       // xyz, w: 1 / range^2
    float4 color;            // rgb: luminous intensity (cd) times color, w: first shadow matrix index, < 0 none
    float4 spotDirectionWS;  // xyz: the spot axis, pointing away from the light; w: 1 spot, 0 point
    float4 spotScaleOffset;  // xy: SpotScaleOffset(cosInner, cosOuter)
};

[[vk::binding(9, 0)]] StructuredBuffer<AdditionalLight> _AdditionalLights : register(t9);
[[vk::binding(10, 0)]] StructuredBuffer<uint> _TileLightIndices : register(t10);
// Spot lights use one matrix, point lights six (one per cube face, +X -X +Y -Y +Z -Z).
[[vk::binding(11, 0)]] StructuredBuffer<float4x4> _AdditionalShadowMatrices : register(t11);

[[vk::binding(12, 0)]] cbuffer ShadowCaster : register(b12)
{
    float4x4 _ShadowViewProjection;
    float4   _ShadowLightPositionWS;      // xyz: punctual light position
    float4   _ShadowLightDirectionWS;     // xyz: unit vector towards a directional light
    float4   _ShadowBias;                 // x depth bias (world units, away from the light), y normal bias (world units)
};

#endif // KILN_INPUT_INCLUDED
// SPDX-License-Identifier: Apache-2.0
