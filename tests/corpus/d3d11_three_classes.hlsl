// corpus: a D3D11-style sample: each register class numbered from 0
// default: K1406
// option: {"shifts": [{"register": "t", "shift": 16}, {"register": "s", "shift": 32}]}
// layout: PerFrame uniform_buffer 0.0, diffuseMap texture 0.16, linearSampler sampler 0.32
// stages: vertex=VSMain fragment=PSMain
cbuffer PerFrame : register(b0)
{
    float4x4 worldViewProj;
    float4 lightDirection;
};

Texture2D diffuseMap : register(t0);
SamplerState linearSampler : register(s0);

struct VSInput { float3 position : POSITION; float3 normal : NORMAL; float2 uv : TEXCOORD0; };
struct PSInput { float4 position : SV_Position; float3 normal : NORMAL; float2 uv : TEXCOORD0; };

PSInput VSMain(VSInput input)
{
    PSInput output;
    output.position = mul(worldViewProj, float4(input.position, 1.0));
    output.normal = input.normal;
    output.uv = input.uv;
    return output;
}

float4 PSMain(PSInput input) : SV_Target
{
    float lambert = saturate(dot(normalize(input.normal), -lightDirection.xyz));
    return diffuseMap.Sample(linearSampler, input.uv) * lambert;
}
