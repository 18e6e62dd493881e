// corpus: per-draw data in a push constant block, one texture and sampler without registers
// default: ok
// layout: sprite texture 0.0, spriteSampler sampler 0.1
// stages: vertex=VSMain fragment=PSMain
struct DrawData { float4x4 transform; float4 color; };
[[vk::push_constant]] ConstantBuffer<DrawData> draw;

Texture2D sprite;
SamplerState spriteSampler;

struct Varyings { float4 position : SV_Position; float2 uv : TEXCOORD0; };

Varyings VSMain(float2 position : POSITION, float2 uv : TEXCOORD0)
{
    Varyings v;
    v.position = mul(draw.transform, float4(position, 0.0, 1.0));
    v.uv = uv;
    return v;
}

float4 PSMain(Varyings v) : SV_Target { return sprite.Sample(spriteSampler, v.uv) * draw.color; }
