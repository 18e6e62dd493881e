// corpus: a texture array and one sampler at one register (t0, s0), which the C++ binds as one combined-image-sampler
// array (sampler2D textures[4]); an element is sampled by a material index, fetched and measured
// default: K1406
// option: {"combined_image_samplers": true}
// layout: textures combined_image_sampler 0.0, Material uniform_buffer 0.1
// stages: vertex=VSMain fragment=PSMain
Texture2D textures[4] : register(t0);
SamplerState textureSampler : register(s0);
cbuffer Material : register(b1) { uint materialIndex; float4 tint; };

struct VSOutput { float4 position : SV_Position; float2 uv : TEXCOORD0; };

VSOutput VSMain(float3 position : POSITION, float2 uv : TEXCOORD0)
{
    VSOutput output;
    output.position = float4(position, 1.0);
    output.uv = uv;
    return output;
}

float4 PSMain(VSOutput input) : SV_Target
{
    uint width, height;
    textures[0].GetDimensions(width, height);
    float4 detail = textures[3].Load(int3(input.uv * float2(width, height), 0));
    return textures[materialIndex].Sample(textureSampler, input.uv) * tint + detail;
}
