// corpus: an FX-era cbuffer with packoffset, a volume texture and a sampler, all at register 0
// default: K1406
// option: {"shifts": [{"register": "t", "shift": 16}, {"register": "s", "shift": 24}]}
// layout: FogParams uniform_buffer 0.0, fogVolume texture 0.16, volumeSampler sampler 0.24
// stages: vertex=VSMain fragment=PSMain
cbuffer FogParams : register(b0)
{
    float4 fogColor : packoffset(c0);
    float fogDensity : packoffset(c1.x);
    float fogHeight : packoffset(c1.y);
};
Texture3D fogVolume : register(t0);
SamplerState volumeSampler : register(s0);

struct Varyings { float4 position : SV_Position; float3 uvw : TEXCOORD0; };

Varyings VSMain(float4 position : POSITION)
{
    Varyings v;
    v.position = position;
    v.uvw = position.xyz * 0.5 + 0.5;
    return v;
}

float4 PSMain(Varyings v) : SV_Target
{
    float density = fogVolume.Sample(volumeSampler, v.uvw).r * fogDensity * saturate(fogHeight - v.uvw.y);
    return float4(fogColor.rgb, saturate(density));
}
