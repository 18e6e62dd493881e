// corpus: single-pass stereo (multiview) as VR renderers write it: SV_ViewID picks the eye's matrix in the vertex
// stage and tints in the fragment stage, which also reads SV_ShadingRate; DXC makes them the ViewIndex and
// ShadingRateKHR built-ins, and so does kiln (glslang 12 gave them user locations, moving the later ones).
// SPIR-V and MSL: GL writes multiview with GL_OVR_multiview2, which needs the view count
// default: ok
// layout: Eyes uniform_buffer 0.0
// stages: vertex=VSMain fragment=PSMain
// targets: spirv msl
cbuffer Eyes : register(b0) { float4x4 viewProjection[2]; float4 eyeTint[2]; };

struct VSOut { float4 position : SV_Position; float3 normal : NORMAL; float2 uv : TEXCOORD0; };

VSOut VSMain(float3 position : POSITION, float3 normal : NORMAL, float2 uv : TEXCOORD0, uint view : SV_ViewID)
{
    VSOut output;
    output.position = mul(viewProjection[view], float4(position, 1.0));
    output.normal = normal;
    output.uv = uv;
    return output;
}

float4 PSMain(VSOut input, uint view : SV_ViewID, uint rate : SV_ShadingRate) : SV_Target
{
    const float coarse = rate != 0 ? 0.5 : 1.0;
    return float4(normalize(input.normal) * 0.5 + 0.5, 1.0) * eyeTint[view] * coarse + float4(input.uv, 0.0, 0.0) * 0.01;
}
