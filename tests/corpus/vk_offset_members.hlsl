// corpus: [[vk::offset(N)]] on cbuffer and struct members, as DXC's SPIR-V users write it: at the offsets HLSL's
// packing gives (nothing to do) and 16 bytes later (a member moved, and those after it); glslang 12 ignored the
// attribute, so kiln would have built another layout. GL and GL ES cannot state offsets std140 does not give
// targets: spirv msl
// default: ok
// layout: Frame uniform_buffer 0.0, light uniform_buffer 0.1
// stages: vertex=MainVS fragment=MainPS
cbuffer Frame : register(b0)
{
    [[vk::offset(0)]] float4x4 viewProjection;
    [[vk::offset(64)]] float3 cameraPosition;
    [[vk::offset(96)]] float time;  // packing gives 76: moved one register later
};

struct Light
{
    [[vk::offset(0)]] float3 direction;
    float intensity;
    [[vk::offset(32)]] float3 color;  // packing gives 16
};
ConstantBuffer<Light> light : register(b1);

struct VSOut { float4 position : SV_Position; float3 normal : NORMAL; };

VSOut MainVS(float3 position : POSITION, float3 normal : NORMAL)
{
    VSOut o;
    o.position = mul(viewProjection, float4(position + normal * sin(time) * 0.01, 1.0));
    o.normal = normal;
    return o;
}

float4 MainPS(VSOut i) : SV_Target
{
    const float lit = saturate(dot(normalize(i.normal), -light.direction)) * light.intensity;
    return float4(light.color * lit + cameraPosition * 0.0, 1.0);
}
