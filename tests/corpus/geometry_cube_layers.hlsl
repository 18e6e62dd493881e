// corpus: single-pass cube shadow rendering: a geometry shader taking triangles, [maxvertexcount(18)], appending
// each triangle to the six faces of a layered target (SV_RenderTargetArrayIndex) with RestartStrip, and reading
// per-face matrices from a StructuredBuffer (t0) beside a cbuffer (b0); no geometry stage in Metal
// default: ok
// targets: spirv glsl gles
// layout: ShadowLight uniform_buffer 0.0, faceMatrices storage_buffer 0.1
// stages: vertex=VSMain geometry=GSMain fragment=PSMain
cbuffer ShadowLight : register(b0) { float3 lightPosition; float farPlane; };
StructuredBuffer<float4x4> faceMatrices : register(t1);

struct VSOut { float4 world : POSITION0; };
struct GSOut { float4 position : SV_Position; float3 toLight : TEXCOORD0; uint face : SV_RenderTargetArrayIndex; };

VSOut VSMain(float3 position : POSITION) { VSOut o; o.world = float4(position, 1.0); return o; }

[maxvertexcount(18)]
void GSMain(triangle VSOut input[3], inout TriangleStream<GSOut> stream)
{
    for (uint face = 0; face < 6; ++face) {
        for (uint v = 0; v < 3; ++v) {
            GSOut o;
            o.position = mul(faceMatrices[face], input[v].world);
            o.toLight = input[v].world.xyz - lightPosition;
            o.face = face;
            stream.Append(o);
        }
        stream.RestartStrip();
    }
}

float PSMain(GSOut i) : SV_Depth { return length(i.toLight) / farPlane; }
