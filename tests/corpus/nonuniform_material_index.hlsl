// corpus: a bindless material system as D3D12 renderers write it: unbounded texture and constant-buffer arrays
// in their own spaces, indexed per pixel through NonUniformResourceIndex (the index varies across a draw's
// pixels); kiln keeps DXC's NonUniform decoration, glslang 12 and glslc reject the intrinsic. SPIR-V only: GL
// has no unbounded arrays outside Vulkan GLSL, and Metal binds them only through argument buffers
// default: ok
// layout: linearWrap sampler 0.0, materialTextures texture 1.0, materials uniform_buffer 2.0
// stages: vertex=VSMain fragment=PSMain
// targets: spirv
struct MaterialConstants { float4 baseColor; uint albedoTexture; uint normalTexture; float roughness; float metallic; };

SamplerState linearWrap : register(s0);
Texture2D materialTextures[] : register(t0, space1);
ConstantBuffer<MaterialConstants> materials[] : register(b0, space2);

struct VSIn { float3 position : POSITION; float2 uv : TEXCOORD0; uint material : MATERIAL; };
struct VSOut { float4 position : SV_Position; float2 uv : TEXCOORD0; nointerpolation uint material : MATERIAL; };

VSOut VSMain(VSIn input)
{
    VSOut output;
    output.position = float4(input.position, 1.0);
    output.uv = input.uv;
    output.material = input.material;
    return output;
}

float4 SampleMaterialTexture(uint index, float2 uv)
{
    return materialTextures[NonUniformResourceIndex(index)].Sample(linearWrap, uv);
}

float4 PSMain(VSOut input) : SV_Target
{
    const uint m = NonUniformResourceIndex(input.material);
    float4 albedo = SampleMaterialTexture(materials[m].albedoTexture, input.uv) * materials[m].baseColor;
    return float4(albedo.rgb * (1.0 - materials[m].metallic * 0.5), albedo.a);
}
