// kiln shaderlib: the DepthNormals pass (seed 004): world-space normal, encoded to [0,1], plus depth.
// It doubles as the geometry buffer the golden tests shade with the CPU reference.
#include "../Common.hlsl"
#include "../Input.hlsl"

struct Attributes
{
    float3 positionOS : POSITION;
    float3 normalOS : NORMAL;
};

struct Varyings
{
    float4 positionCS : SV_Position;
    float3 normalWS : TEXCOORD0;
};

Varyings DepthNormalsVertex(Attributes input)
{
    Varyings output;
    output.positionCS = mul(_ViewProjection, mul(_ObjectToWorld, float4(input.positionOS, 1.0)));
    output.normalWS = SafeNormalize(mul(input.normalOS, (float3x3)_WorldToObject), float3(0.0, 1.0, 0.0));
    return output;
}

float4 DepthNormalsFragment(Varyings input) : SV_Target
{
    float3 normalWS = SafeNormalize(input.normalWS, float3(0.0, 1.0, 0.0));
    return float4(normalWS * 0.5 + 0.5, 1.0);
}
// SPDX-License-Identifier: Apache-2.0
