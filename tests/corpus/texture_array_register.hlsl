// corpus: a bindless-lite array of textures at t0 (one descriptor array) and a sampler at s0
// default: K1406
// option: {"shifts": [{"register": "s", "shift": 8}]}
// layout: materials texture 0.0, anisotropic sampler 0.8
// stages: vertex=VSMain fragment=PSMain
Texture2D materials[4] : register(t0);
SamplerState anisotropic : register(s0);

struct Varyings { float4 position : SV_Position; float2 uv : TEXCOORD0; nointerpolation uint material : MATERIAL; };

Varyings VSMain(float4 position : POSITION, float2 uv : TEXCOORD0, uint material : MATERIAL)
{
    Varyings v;
    v.position = position;
    v.uv = uv;
    v.material = material;
    return v;
}

float4 PSMain(Varyings v) : SV_Target
{
    float4 color = 0;
    [unroll] for (uint i = 0; i < 4; ++i) color += materials[i].Sample(anisotropic, v.uv) * (v.material == i ? 1.0 : 0.0);
    return color;
}
