// corpus: a port in progress: some resources moved to [[vk::binding]], the rest still on D3D registers
// default: K1406
// option: {"shifts": [{"register": "t", "shift": 8}, {"register": "s", "shift": 12}]}
// layout: Frame uniform_buffer 0.0, environment texture 0.1, environmentSampler sampler 0.2, detail texture 0.8, detailSampler sampler 0.12
// stages: vertex=VSMain fragment=PSMain
[[vk::binding(0)]] cbuffer Frame : register(b0) { float4x4 viewProjection; float detailScale; };
[[vk::binding(1)]] TextureCube environment : register(t0);
[[vk::binding(2)]] SamplerState environmentSampler : register(s0);
Texture2D detail : register(t0);
SamplerState detailSampler : register(s0);

struct Varyings { float4 position : SV_Position; float3 direction : TEXCOORD0; };

Varyings VSMain(float3 position : POSITION)
{
    Varyings v;
    v.position = mul(viewProjection, float4(position, 1.0));
    v.direction = position;
    return v;
}

float4 PSMain(Varyings v) : SV_Target
{
    float4 sky = environment.Sample(environmentSampler, v.direction);
    return sky * detail.Sample(detailSampler, v.direction.xz * detailScale);
}
