// kiln shaderlib: the Forward pass of the Lit shader (vertex LitVertex, fragment LitFragment).
// Keyword declarations, grouped as URP's Lit.shader groups them. multi_compile: chosen at run time by the
// renderer, every combination may be needed. shader_feature: chosen by materials, stripped by the pack's
// material list. _vertex / _fragment: the keyword changes only that stage's code.

// ---- Main light shadows
#pragma multi_compile _ _MAIN_LIGHT_SHADOWS _MAIN_LIGHT_SHADOWS_CASCADE
#pragma multi_compile_fragment _ _SHADOWS_SOFT
// ---- Additional lights: per vertex, or per pixel (plain loop or Forward+ tiles), optionally shadowed
#pragma multi_compile _ _ADDITIONAL_LIGHTS_VERTEX _ADDITIONAL_LIGHTS
#pragma multi_compile_fragment _ _ADDITIONAL_LIGHT_SHADOWS
#pragma multi_compile_fragment _ _FORWARD_PLUS
// ---- Fog: the vertex stage computes the fog depth, the fragment stage the fog factor
#pragma multi_compile_fog
// ---- Energy compensation for multiple scattering (needs the DFG table)
#pragma multi_compile_fragment _ _MULTISCATTER
// ---- Material features
#pragma shader_feature_local _ _ANISOTROPY
#pragma shader_feature_local_fragment _ _DIFFUSE_BURLEY
#pragma shader_feature_local_fragment _ _ENV_BRDF_APPROX
#pragma shader_feature_local_fragment _ _MOBILE_BRDF
#pragma shader_feature_local_fragment _ _SPECULARHIGHLIGHTS_OFF
#pragma shader_feature_local_fragment _ _ENVIRONMENTREFLECTIONS_OFF
#pragma shader_feature_local _ _HALF_PRECISION
// ---- Output: linear radiance instead of ACES (for tests comparing radiance); a per-material debug mode
#pragma shader_feature_local_fragment _ _LINEAR_OUTPUT

#include "../Lighting.hlsl"
// Feature files only where used: an edit to Fog.hlsl recompiles only the fog variants.
#if defined(FOG_LINEAR) || defined(FOG_EXP) || defined(FOG_EXP2)
#include "../Fog.hlsl"
#endif
#if !defined(_LINEAR_OUTPUT)
#include "../Tonemap.hlsl"
#endif

struct Attributes
{
    float3 positionOS : POSITION;
    float3 normalOS : NORMAL;
    float4 tangentOS : TANGENT;
    float2 uv : TEXCOORD0;
};

struct Varyings
{
    float4 positionCS : SV_Position;
    float3 positionWS : TEXCOORD0;
    float3 normalWS : TEXCOORD1;
#if defined(_ANISOTROPY)
    float4 tangentWS : TEXCOORD2;  // w: bitangent sign
#endif
#if defined(_ADDITIONAL_LIGHTS_VERTEX)
    float3 vertexLighting : TEXCOORD3;
#endif
#if defined(_MAIN_LIGHT_SHADOWS)
    float3 shadowCoord : TEXCOORD4;  // single cascade: projected per vertex; cascades select per pixel
#endif
#if defined(KILN_FOG)
    float fogDepth : TEXCOORD5;      // view depth: linear in the position, so interpolation is exact
#endif
};

Varyings LitVertex(Attributes input)
{
    Varyings output;
    float4 positionWS = mul(_ObjectToWorld, float4(input.positionOS, 1.0));
    output.positionWS = positionWS.xyz;
    output.positionCS = mul(_ViewProjection, positionWS);
    // Normals transform by the inverse transpose; the zero-length fallback keeps a degenerate mesh finite.
    output.normalWS = SafeNormalize(mul(input.normalOS, (float3x3)_WorldToObject), float3(0.0, 1.0, 0.0));
#if defined(_ANISOTROPY)
    output.tangentWS = float4(SafeNormalize(mul((float3x3)_ObjectToWorld, input.tangentOS.xyz), float3(1.0, 0.0, 0.0)),
                              input.tangentOS.w < 0.0 ? -1.0 : 1.0);
#endif
#if defined(_ADDITIONAL_LIGHTS_VERTEX)
    output.vertexLighting = VertexLighting(output.positionWS, output.normalWS);
#endif
#if defined(_MAIN_LIGHT_SHADOWS)
    output.shadowCoord = MainLightShadowCoord(output.positionWS, 0);
#endif
#if defined(KILN_FOG)
    output.fogDepth = ComputeFogDepth(output.positionWS, _CameraPositionWS.xyz, _CameraForwardWS.xyz);
#endif
    return output;
}

SurfaceData InitializeSurface(Varyings input, bool frontFace)
{
    SurfaceData surface;
    surface.baseColor = (real3)_BaseColor.rgb;
    surface.metallic = (real)_Metallic;
    surface.perceptualRoughness = (real)_PerceptualRoughness;
    surface.reflectance = (real)_Reflectance;
    surface.anisotropy = (real)clamp(_Anisotropy, -1.0, 1.0);
    float3 normalWS = SafeNormalize(input.normalWS, float3(0.0, 1.0, 0.0));
    surface.normalWS = frontFace ? normalWS : -normalWS;
#if defined(_ANISOTROPY)
    // Gram-Schmidt: the interpolated tangent drifts off perpendicular; the fallback covers T parallel to N.
    float3 tangent = input.tangentWS.xyz - surface.normalWS * dot(surface.normalWS, input.tangentWS.xyz);
    surface.tangentWS = SafeNormalize(tangent, abs(surface.normalWS.x) < 0.9 ? float3(1.0, 0.0, 0.0) : float3(0.0, 0.0, 1.0));
    surface.bitangentWS = cross(surface.normalWS, surface.tangentWS) * input.tangentWS.w;
#else
    surface.tangentWS = float3(1.0, 0.0, 0.0);
    surface.bitangentWS = float3(0.0, 0.0, 1.0);
#endif
    surface.viewWS = SafeNormalize(_CameraPositionWS.xyz - input.positionWS, surface.normalWS);
    return surface;
}

float4 LitFragment(Varyings input, bool frontFace : SV_IsFrontFace) : SV_Target
{
    SurfaceData surface = InitializeSurface(input, frontFace);
    real NoVForTable = (real)max(dot(surface.normalWS, surface.viewWS), MIN_N_DOT_V);
    // The DFG table describes the lobe the BRDF evaluates, so it is indexed by the clamped roughness (IBL.hlsl);
    // the prefiltered mips stay indexed by the authored one (seed 000).
    real2 dfg = SampleDFG(_DFG, sampler_LinearClamp, NoVForTable, ClampedPerceptualRoughness(surface.perceptualRoughness));
    ShadingData s = PrepareShading(surface, dfg);

    // Main light.
#if defined(_MAIN_LIGHT_SHADOWS)
    float3 vertexShadowCoord = input.shadowCoord;
#else
    float3 vertexShadowCoord = float3(0.0, 0.0, 0.0);
#endif
    // Radiance is summed in fp32 even in _HALF_PRECISION variants: one light's term can exceed the fp16 range,
    // and so can a sum of several (the stress gate found Inf there).
    float3 color = AccumulateLight(s, GetMainLight(input.positionWS, vertexShadowCoord));

    // Additional lights.
#if defined(_ADDITIONAL_LIGHTS)
    color += AdditionalLightsRadiance(s, input.positionWS, input.positionCS.xy);
#elif defined(_ADDITIONAL_LIGHTS_VERTEX)
    color += (float3)s.diffuseColor * input.vertexLighting;
#endif

    // Image-based lighting.
    float3 irradianceOverPi = SampleSH9(_AmbientSH, s.N);
#if defined(_ENVIRONMENTREFLECTIONS_OFF)
    float3 prefiltered = _GlossyEnvironmentColor.rgb;
#else
    float3 R = reflect(-s.V, s.N);
    if (_ProbePositionWS.w > 0.0)
        R = BoxProjectedDirection(R, input.positionWS, _ProbePositionWS.xyz, _ProbeBoxMin.xyz, _ProbeBoxMax.xyz);
    float3 prefiltered = SamplePrefilteredEnvironment(_EnvironmentMap, sampler_LinearClamp, R, saturate(_PerceptualRoughness),
                                                      _EnvironmentParams.x);
#endif
    color += (float3)IndirectLighting(s, irradianceOverPi * _EnvironmentParams.z, prefiltered * _EnvironmentParams.z);

    float3 radiance = color;
#if defined(KILN_FOG)
    float fogFactor = ComputeFogFactor(input.fogDepth, _FogParams);
    radiance = MixFog(radiance, _FogColor.rgb, fogFactor);
#endif
    radiance *= _EnvironmentParams.y;  // exposure
#if defined(_LINEAR_OUTPUT)
    return float4(radiance, 1.0);
#else
    return float4(ACESFitted(radiance), 1.0);
#endif
}
// SPDX-License-Identifier: Apache-2.0
