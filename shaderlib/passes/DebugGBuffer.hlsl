// kiln shaderlib: the GBuffer debug pass (variants/debug.pack.json). It writes what the Forward pass's
// fragment stage receives - the interpolated world position, normal and tangent, exactly as LitVertex
// computes them - and the material constants, so that the CPU reference can shade the very same pixels in
// double precision (kiln test). No lighting code: geometry and material data only.
#include "../Common.hlsl"
#include "../Input.hlsl"

struct Attributes
{
    float3 positionOS : POSITION;
    float3 normalOS : NORMAL;
    float4 tangentOS : TANGENT;
};

struct Varyings
{
    float4 positionCS : SV_Position;
    float3 positionWS : TEXCOORD0;
    float3 normalWS : TEXCOORD1;
    float4 tangentWS : TEXCOORD2;
};

struct GBufferOutput
{
    float4 position : SV_Target0;   // xyz world position, w 1 (covered)
    float4 normal : SV_Target1;     // xyz interpolated world normal (not renormalized), w +1 front / -1 back face
    float4 tangent : SV_Target2;    // xyz interpolated world tangent, w bitangent sign
    float4 material0 : SV_Target3;  // rgb base color, a metallic
    float4 material1 : SV_Target4;  // x perceptual roughness, y reflectance, z anisotropy
};

// The same expressions as LitVertex (passes/LitForward.hlsl), so the interpolated values are the same.
Varyings GBufferVertex(Attributes input)
{
    Varyings output;
    float4 positionWS = mul(_ObjectToWorld, float4(input.positionOS, 1.0));
    output.positionWS = positionWS.xyz;
    output.positionCS = mul(_ViewProjection, positionWS);
    output.normalWS = SafeNormalize(mul(input.normalOS, (float3x3)_WorldToObject), float3(0.0, 1.0, 0.0));
    output.tangentWS = float4(SafeNormalize(mul((float3x3)_ObjectToWorld, input.tangentOS.xyz), float3(1.0, 0.0, 0.0)),
                              input.tangentOS.w < 0.0 ? -1.0 : 1.0);
    return output;
}

GBufferOutput GBufferFragment(Varyings input, bool frontFace : SV_IsFrontFace)
{
    GBufferOutput output;
    output.position = float4(input.positionWS, 1.0);
    output.normal = float4(input.normalWS, frontFace ? 1.0 : -1.0);
    output.tangent = input.tangentWS;
    output.material0 = float4(_BaseColor.rgb, _Metallic);
    output.material1 = float4(_PerceptualRoughness, _Reflectance, _Anisotropy, 0.0);
    return output;
}
// SPDX-License-Identifier: Apache-2.0
