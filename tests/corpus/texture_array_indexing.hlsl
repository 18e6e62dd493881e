// corpus: an array of textures indexed by a material id (bindless-lite), a Texture2DArray, and a comparison sampler,
// registers in space 1 for the material set (D3D12 style)
// default: ok
// layout: materialTextures texture 1.0, shadowCascades texture 1.4, materialSampler sampler 1.5, shadowSampler sampler 1.6
// stages: vertex=VSMain fragment=PSMain
Texture2D<float4> materialTextures[4] : register(t0, space1);
Texture2DArray<float> shadowCascades : register(t4, space1);
SamplerState materialSampler : register(s5, space1);
SamplerComparisonState shadowSampler : register(s6, space1);

struct Varyings
{
    float4 position : SV_Position;
    float2 uv : TEXCOORD0;
    float3 shadowCoord : TEXCOORD1;
    nointerpolation uint material : MATERIAL;
};

Varyings VSMain(float3 position : POSITION, float2 uv : TEXCOORD0, uint material : MATERIAL)
{
    Varyings output;
    output.position = float4(position, 1.0);
    output.uv = uv;
    output.shadowCoord = float3(position.xy * 0.5 + 0.5, position.z);
    output.material = material;
    return output;
}

float4 PSMain(Varyings input) : SV_Target
{
    float4 albedo = materialTextures[input.material & 3].Sample(materialSampler, input.uv);
    float lit = shadowCascades.SampleCmpLevelZero(shadowSampler, float3(input.shadowCoord.xy, 1.0), input.shadowCoord.z);
    return float4(albedo.rgb * lit, albedo.a);
}
