// corpus: enums as DXC users write them: an unscoped enum with a stated value, an `enum class` with a type, both
// used qualified and unqualified, in a switch, a cast and a parameter; glslang 12 refused `enum` ("Reserved word"),
// kiln makes each a typedef and constants (frontend/hlsl_compat.hpp)
// default: ok
// layout: Params uniform_buffer 0.0, albedo texture 0.1, albedoSampler sampler 0.2
// stages: vertex=MainVS fragment=MainPS
enum DebugView { DebugNone, DebugAlbedo = 2, DebugNormal };
enum class Tonemapper : uint { Linear, Reinhard, Aces = Reinhard + 2 };

cbuffer Params : register(b0)
{
    int debugView;
    uint tonemapper;
    float exposure;
};
Texture2D<float4> albedo : register(t1);
SamplerState albedoSampler : register(s2);

struct VSOut { float4 position : SV_Position; float2 uv : TEXCOORD0; float3 normal : NORMAL; };

VSOut MainVS(float3 position : POSITION, float2 uv : TEXCOORD0, float3 normal : NORMAL)
{
    VSOut o;
    o.position = float4(position, 1.0);
    o.uv = uv;
    o.normal = normal;
    return o;
}

float3 Tonemap(float3 color, Tonemapper mapper)
{
    switch (mapper)
    {
    case Tonemapper::Reinhard: return color / (1.0 + color);
    case Tonemapper::Aces: return saturate((color * (2.51 * color + 0.03)) / (color * (2.43 * color + 0.59) + 0.14));
    default: return color;
    }
}

float4 MainPS(VSOut i) : SV_Target
{
    const DebugView view = (DebugView)debugView;
    if (view == DebugNormal) return float4(i.normal * 0.5 + 0.5, 1.0);
    float4 color = albedo.Sample(albedoSampler, i.uv);
    if (view == DebugView::DebugAlbedo) return color;
    return float4(Tonemap(color.rgb * exposure, (Tonemapper)tonemapper), color.a);
}
