// kiln shaderlib: the DepthOnly pass (seed 004): clip-space position only; the fragment writes depth.
#include "../Common.hlsl"
#include "../Input.hlsl"

struct Attributes
{
    float3 positionOS : POSITION;
};

struct Varyings
{
    float4 positionCS : SV_Position;
};

Varyings DepthOnlyVertex(Attributes input)
{
    Varyings output;
    output.positionCS = mul(_ViewProjection, mul(_ObjectToWorld, float4(input.positionOS, 1.0)));
    return output;
}

float4 DepthOnlyFragment(Varyings input) : SV_Target
{
    return float4(input.positionCS.z, 0.0, 0.0, 1.0);
}
// SPDX-License-Identifier: Apache-2.0
