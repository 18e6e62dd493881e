// corpus: SM 5.1 ConstantBuffer<T> and a texture array, both at register number 1 of their class
// default: K1406
// option: {"shifts": [{"register": "t", "shift": 16}]}
// layout: material uniform_buffer 0.1, layerSampler sampler 0.2, layers texture 0.17
// stages: vertex=VSMain fragment=PSMain
struct Material { float4 baseColor; float layer; };
ConstantBuffer<Material> material : register(b1);
Texture2DArray layers : register(t1);
SamplerState layerSampler : register(s2);

float4 VSMain(float4 position : POSITION) : SV_Position { return position; }

float4 PSMain(float4 position : SV_Position) : SV_Target
{
    return layers.Sample(layerSampler, float3(position.xy, material.layer)) * material.baseColor;
}
