// corpus: a geometry shader expanding points into camera-facing quads (particles); Metal has no geometry stage,
// so the pack ships SPIR-V, GLSL and GLSL ES (ES needs GL_EXT_geometry_shader, which SPIRV-Cross requires)
// default: ok
// targets: spirv glsl gles
// layout: Camera uniform_buffer 0.0
// stages: vertex=VSMain geometry=GSMain fragment=PSMain
cbuffer Camera : register(b0) { float4x4 viewProjection; float3 cameraRight; float size; float3 cameraUp; };

struct Particle { float3 position : POSITION; float4 color : COLOR0; };
struct Sprite { float4 position : SV_Position; float4 color : COLOR0; float2 uv : TEXCOORD0; };

Particle VSMain(Particle p) { return p; }

[maxvertexcount(4)]
void GSMain(point Particle input[1], inout TriangleStream<Sprite> stream)
{
    const float2 corners[4] = { float2(-1, -1), float2(-1, 1), float2(1, -1), float2(1, 1) };
    for (int i = 0; i < 4; ++i) {
        Sprite s;
        float3 world = input[0].position + (cameraRight * corners[i].x + cameraUp * corners[i].y) * size;
        s.position = mul(viewProjection, float4(world, 1));
        s.color = input[0].color;
        s.uv = corners[i] * 0.5 + 0.5;
        stream.Append(s);
    }
}

float4 PSMain(Sprite s) : SV_Target { return s.color * saturate(1 - length(s.uv * 2 - 1)); }
