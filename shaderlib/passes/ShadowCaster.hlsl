// kiln shaderlib: the ShadowCaster pass (seed 004): depth only, with caster-side depth and normal bias.
// _CASTING_PUNCTUAL_LIGHT_SHADOW: the light direction comes from the light's position (point/spot)
// instead of a fixed direction (directional light).
#pragma multi_compile_vertex _ _CASTING_PUNCTUAL_LIGHT_SHADOW

#include "../Common.hlsl"
#include "../Input.hlsl"
#include "../Shadows.hlsl"

struct Attributes
{
    float3 positionOS : POSITION;
    float3 normalOS : NORMAL;
};

struct Varyings
{
    float4 positionCS : SV_Position;
};

Varyings ShadowPassVertex(Attributes input)
{
    Varyings output;
    float3 positionWS = mul(_ObjectToWorld, float4(input.positionOS, 1.0)).xyz;
    float3 normalWS = SafeNormalize(mul(input.normalOS, (float3x3)_WorldToObject), float3(0.0, 1.0, 0.0));
#if defined(_CASTING_PUNCTUAL_LIGHT_SHADOW)
    float3 lightDirectionWS = SafeNormalize(_ShadowLightPositionWS.xyz - positionWS, normalWS);
#else
    float3 lightDirectionWS = _ShadowLightDirectionWS.xyz;
#endif
    positionWS = ApplyShadowBias(positionWS, normalWS, lightDirectionWS, _ShadowBias.x, _ShadowBias.y);
    output.positionCS = mul(_ShadowViewProjection, float4(positionWS, 1.0));
    return output;
}

float4 ShadowPassFragment(Varyings input) : SV_Target
{
    return 0.0;
}
// SPDX-License-Identifier: Apache-2.0
