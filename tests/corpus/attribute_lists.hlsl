// corpus: attributes written as a list, as DXC takes them (clang's syntax): `[[vk::input_attachment_index(0),
// vk::binding(1, 0)]]`; glslang 12's grammar takes one attribute per group and stops at the comma ("']' :
// Expected"); kiln reads a list as one group per attribute
// default: ok
// layout: Material uniform_buffer 0.0, previousFrame input_attachment 0.1, detail texture 1.0, detailSampler sampler 1.1
// stages: vertex=VSMain fragment=PSMain
[[vk::binding(0, 0)]] cbuffer Material { float4 tint; float blend; };
[[vk::input_attachment_index(0), vk::binding(1, 0)]] SubpassInput<float4> previousFrame;
[[vk::binding(0, 1)]] Texture2D detail;
[[vk::binding(1, 1)]] SamplerState detailSampler;

struct VSOut { float4 position : SV_Position; [[vk::location(0)]] float2 uv : TEXCOORD0; };

VSOut VSMain([[vk::location(0)]] float3 position : POSITION, [[vk::location(1)]] float2 uv : TEXCOORD0)
{
    VSOut o;
    o.position = float4(position, 1.0);
    o.uv = uv;
    return o;
}

float4 PSMain(VSOut i) : SV_Target
{
    const float4 previous = previousFrame.SubpassLoad();
    return lerp(detail.Sample(detailSampler, i.uv) * tint, previous, blend);
}
