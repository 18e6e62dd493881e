// corpus: a cube shadow map with a comparison sampler, the light data in a cbuffer, all at number 0
// default: K1406
// option: {"shifts": [{"register": "t", "shift": 16}, {"register": "s", "shift": 32}]}
// layout: PointLight uniform_buffer 0.0, shadowCube texture 0.16, shadowCompare sampler 0.32
// stages: vertex=VSMain fragment=PSMain
cbuffer PointLight : register(b0) { float3 lightPosition; float farPlane; };
TextureCube<float> shadowCube : register(t0);
SamplerComparisonState shadowCompare : register(s0);

struct Varyings { float4 position : SV_Position; float3 worldPosition : TEXCOORD0; };

Varyings VSMain(float3 position : POSITION)
{
    Varyings o;
    o.position = float4(position, 1.0);
    o.worldPosition = position;
    return o;
}

float4 PSMain(Varyings i) : SV_Target
{
    float3 toLight = i.worldPosition - lightPosition;
    float lit = shadowCube.SampleCmpLevelZero(shadowCompare, toLight, length(toLight) / farPlane);
    return float4(lit.xxx, 1.0);
}
