// corpus: push constants spelled as DXC users write them, `[[vk::push_constant]] DrawPush push;` with a struct type,
// read by both stages beside a texture (t0) and sampler (s0) with registers; glslang 12 and glslc would make the
// struct a member of the $Global uniform buffer, kiln rewrites it into the ConstantBuffer<T> form (docs/bindings.md)
// default: K1406
// option: {"shifts": [{"register": "s", "shift": 1}]}
// layout: baseColor texture 0.0, baseSampler sampler 0.1
// stages: vertex=VSMain fragment=PSMain
struct DrawPush
{
    float4x4 model;
    float4 tint;
    uint textureFlags;
    float alphaCutoff;
};

[[vk::push_constant]] DrawPush push;

Texture2D baseColor : register(t0);
SamplerState baseSampler : register(s0);

struct Interpolants { float4 position : SV_Position; float2 uv : TEXCOORD0; };

Interpolants VSMain(float3 position : POSITION, float2 uv : TEXCOORD0)
{
    Interpolants o;
    o.position = mul(push.model, float4(position, 1.0));
    o.uv = uv;
    return o;
}

float4 PSMain(Interpolants i) : SV_Target
{
    float4 color = push.tint;
    if (push.textureFlags & 1u) color *= baseColor.Sample(baseSampler, i.uv);
    clip(color.a - push.alphaCutoff);
    return color;
}
