// corpus: single-pass stereo with every varying located by [[vk::location]] (DXC wants all or none located): SV_ViewID
// among three located inputs and SV_ShadingRate among them in the fragment stage; the built-ins took glslang's
// automatic locations and moving the later ones down put a located input onto another (spirv-val's "conflicting
// input location"); the stated locations stay. SPIR-V and MSL: GL writes multiview with GL_OVR_multiview2
// default: ok
// layout: Eyes uniform_buffer 0.0
// stages: vertex=VSMain fragment=PSMain
// targets: spirv msl
cbuffer Eyes : register(b0) { float4x4 viewProjection[2]; float4 eyeTint[2]; };

struct VSOut
{
    float4 position : SV_Position;
    [[vk::location(0)]] float3 normal : NORMAL;
    [[vk::location(1)]] float2 uv : TEXCOORD0;
    [[vk::location(2)]] float4 color : COLOR0;
};

VSOut VSMain(uint view : SV_ViewID, [[vk::location(0)]] float3 position : POSITION, [[vk::location(1)]] float3 normal : NORMAL,
             [[vk::location(2)]] float2 uv : TEXCOORD0, [[vk::location(3)]] float4 color : COLOR0)
{
    VSOut output;
    output.position = mul(viewProjection[view], float4(position, 1.0));
    output.normal = normal;
    output.uv = uv;
    output.color = color;
    return output;
}

struct PSIn
{
    uint view : SV_ViewID;
    [[vk::location(0)]] float3 normal : NORMAL;
    uint rate : SV_ShadingRate;
    [[vk::location(1)]] float2 uv : TEXCOORD0;
    [[vk::location(2)]] float4 color : COLOR0;
};

float4 PSMain(PSIn input) : SV_Target
{
    const float coarse = input.rate != 0 ? 0.5 : 1.0;
    return float4(normalize(input.normal) * 0.5 + 0.5, 1.0) * eyeTint[input.view] * input.color * coarse + float4(input.uv, 0.0, 0.0) * 0.01;
}
