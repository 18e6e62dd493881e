// corpus: resources named with words glslang 12's HLSL scanner reserves and DXC takes (`Texture2D texture;`,
// `SamplerState sampler;`); glslang said "';' : Expected" with no column. kiln renames them for glslang and gives
// the module, and so the reflection, the author's names back
// default: ok
// layout: texture texture 0.0, sampler sampler 0.1
// stages: vertex=MainVS fragment=MainPS
Texture2D texture : register(t0);
SamplerState sampler : register(s1);

struct VSOut { float4 position : SV_Position; float2 uv : TEXCOORD0; };

VSOut MainVS(float2 position : POSITION)
{
    VSOut o;
    o.position = float4(position, 0.0, 1.0);
    o.uv = position * 0.5 + 0.5;
    return o;
}

float4 MainPS(VSOut input) : SV_Target
{
    return texture.Sample(sampler, input.uv);
}
