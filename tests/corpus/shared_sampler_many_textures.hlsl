// corpus: one sampler shared by three textures (t0-t2, s0): the combined mode cannot pair them, shifts can
// default: K1406
// option: {"shifts": [{"register": "s", "shift": 16}]}
// layout: albedoMap texture 0.0, normalMap texture 0.1, roughnessMap texture 0.2, sharedSampler sampler 0.16
// stages: vertex=VSMain fragment=PSMain
Texture2D albedoMap : register(t0);
Texture2D normalMap : register(t1);
Texture2D roughnessMap : register(t2);
SamplerState sharedSampler : register(s0);

struct Varyings { float4 position : SV_Position; float2 uv : TEXCOORD0; };

Varyings VSMain(float4 position : POSITION, float2 uv : TEXCOORD0)
{
    Varyings v;
    v.position = position;
    v.uv = uv;
    return v;
}

float4 PSMain(Varyings v) : SV_Target
{
    float3 n = normalMap.Sample(sharedSampler, v.uv).xyz;
    float r = roughnessMap.Sample(sharedSampler, v.uv).r;
    return albedoMap.Sample(sharedSampler, v.uv) * saturate(n.z) * (1.0 - r);
}
