// corpus: Vulkan HLSL samples that bind combined image samplers from C++: texture tN with sampler sN
// default: K1406
// option: {"combined_image_samplers": true}
// layout: Transforms uniform_buffer 0.0, textureColor combined_image_sampler 0.1, textureNormal combined_image_sampler 0.2
// stages: vertex=VSMain fragment=PSMain
struct UBO { float4x4 projection; float4x4 model; };
cbuffer Transforms : register(b0) { UBO ubo; };

Texture2D textureColor : register(t1);
SamplerState samplerColor : register(s1);
Texture2D textureNormal : register(t2);
SamplerState samplerNormal : register(s2);

struct VSOutput { float4 Pos : SV_POSITION; float2 UV : TEXCOORD0; };

VSOutput VSMain(float3 Pos : POSITION0, float2 UV : TEXCOORD0)
{
    VSOutput output = (VSOutput)0;
    output.UV = UV;
    output.Pos = mul(ubo.projection, mul(ubo.model, float4(Pos, 1.0)));
    return output;
}

float4 PSMain(VSOutput input) : SV_TARGET
{
    float3 normal = textureNormal.Sample(samplerNormal, input.UV).rgb;
    return textureColor.Sample(samplerColor, input.UV) * normal.z;
}
