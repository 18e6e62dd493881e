#include "../gbuffer_stage_per_file_names.hlsl"
cbuffer ObjectConstants : register(b1) { float4x4 model; };
Texture2D albedoMap : register(t2);
Texture2D normalMap : register(t3);
SamplerState gbufferSampler : register(s4);

struct GBuffer { float4 albedo : SV_Target0; float4 normal : SV_Target1; };

GBuffer main(float4 position : SV_Position, float3 normal : NORMAL, float2 uv : TEXCOORD0)
{
    GBuffer output;
    output.albedo = albedoMap.Sample(gbufferSampler, uv);
    const float3 detail = normalMap.Sample(gbufferSampler, uv).xyz * 2.0 - 1.0;
    output.normal = float4(normalize(mul((float3x3)model, normal) + detail * 0.1) * 0.5 + 0.5, time);
    return output;
}
