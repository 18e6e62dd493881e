// corpus: D3D12 root-signature style: per-space tables, each class from 0 inside its space
// default: K1406
// option: {"shifts": [{"register": "s", "shift": 8, "space": 1}]}
// layout: Camera uniform_buffer 0.0, materialTexture texture 1.0, normalTexture texture 1.1, materialSampler sampler 1.8
// stages: vertex=VSMain fragment=PSMain
cbuffer Camera : register(b0, space0) { float4x4 viewProjection; };

Texture2D materialTexture : register(t0, space1);
Texture2D normalTexture : register(t1, space1);
SamplerState materialSampler : register(s0, space1);

struct Varyings { float4 position : SV_Position; float2 uv : TEXCOORD0; };

Varyings VSMain(float3 position : POSITION, float2 uv : TEXCOORD0)
{
    Varyings v;
    v.position = mul(viewProjection, float4(position, 1.0));
    v.uv = uv;
    return v;
}

float4 PSMain(Varyings v) : SV_Target
{
    float3 n = normalTexture.Sample(materialSampler, v.uv).xyz * 2.0 - 1.0;
    return materialTexture.Sample(materialSampler, v.uv) * saturate(n.z);
}
