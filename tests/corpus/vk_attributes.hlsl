// corpus: HLSL written for Vulkan first: [[vk::binding]] on every resource, [[vk::location]] on stage inputs
// default: ok
// option: {"shifts": [{"register": "t", "shift": 100}, {"register": "b", "shift": 100}]}
// layout: Scene uniform_buffer 0.0, albedo texture 0.1, albedoSampler sampler 0.2, shadowMap texture 1.0
// stages: vertex=VSMain fragment=PSMain
[[vk::binding(0, 0)]] cbuffer Scene : register(b3) { float4x4 viewProjection; float4 sunDirection; };
[[vk::binding(1, 0)]] Texture2D albedo : register(t4);
[[vk::binding(2, 0)]] SamplerState albedoSampler : register(s4);
[[vk::binding(0, 1)]] Texture2D<float> shadowMap;

struct VSOut { float4 position : SV_Position; [[vk::location(0)]] float2 uv : TEXCOORD0; };

VSOut VSMain([[vk::location(0)]] float3 position : POSITION, [[vk::location(1)]] float2 uv : TEXCOORD0)
{
    VSOut o;
    o.position = mul(viewProjection, float4(position, 1.0));
    o.uv = uv;
    return o;
}

float4 PSMain(VSOut i) : SV_Target
{
    float shadow = shadowMap.Sample(albedoSampler, i.uv);
    return albedo.Sample(albedoSampler, i.uv) * shadow * saturate(sunDirection.w);
}
