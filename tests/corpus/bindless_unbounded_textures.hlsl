// corpus: bindless textures as D3D12 renderers declare them: an unbounded Texture2D array in its own space
// (one runtime descriptor array, as DXC makes it; glslang 12 sized it 1), indexed by a material id from a per-draw
// cbuffer; the sampler and cbuffer in space 0. SPIR-V only: GL has no unbounded arrays outside Vulkan GLSL, and
// Metal binds them only through argument buffers (each a K1405 that says so).
// default: ok
// layout: DrawConstants uniform_buffer 0.0, linearSampler sampler 0.1, bindlessTextures texture 1.0
// stages: vertex=VSMain fragment=PSMain
// targets: spirv
cbuffer DrawConstants : register(b0) { float4x4 worldViewProj; uint albedoIndex; uint emissiveIndex; float emissiveScale; };
SamplerState linearSampler : register(s1);
Texture2D bindlessTextures[] : register(t0, space1);

struct VSOut { float4 position : SV_Position; float2 uv : TEXCOORD0; };

VSOut VSMain(float3 position : POSITION, float2 uv : TEXCOORD0)
{
    VSOut o;
    o.position = mul(worldViewProj, float4(position, 1.0));
    o.uv = uv;
    return o;
}

float4 PSMain(VSOut i) : SV_Target
{
    float4 albedo = bindlessTextures[albedoIndex].Sample(linearSampler, i.uv);
    float3 emissive = bindlessTextures[emissiveIndex].Sample(linearSampler, i.uv).rgb * emissiveScale;
    return float4(albedo.rgb + emissive, albedo.a);
}
