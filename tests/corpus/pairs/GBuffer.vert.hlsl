#include "../gbuffer_stage_per_file_names.hlsl"
cbuffer PerObject : register(b1) { float4x4 world; float4x4 worldInverseTranspose; };

struct VSOut { float4 position : SV_Position; float3 normal : NORMAL; float2 uv : TEXCOORD0; };

VSOut main(float3 position : POSITION, float3 normal : NORMAL, float2 uv : TEXCOORD0)
{
    VSOut output;
    output.position = mul(viewProjection, mul(world, float4(position, 1.0)));
    output.normal = mul((float3x3)worldInverseTranspose, normal);
    output.uv = uv;
    return output;
}
