// corpus: hull and domain shaders (tessellation of a triangle patch with a distance-based factor); Metal runs
// tessellation differently, so the pack ships SPIR-V, GLSL and GLSL ES (GL_EXT_tessellation_shader on ES 3.1)
// default: ok
// targets: spirv glsl gles
// layout: Tessellation uniform_buffer 0.0
// stages: vertex=VSMain hull=HSMain domain=DSMain fragment=PSMain
cbuffer Tessellation : register(b0) { float4x4 viewProjection; float3 eye; float maxFactor; };

struct ControlPoint { float3 position : POSITION; float3 normal : NORMAL; };
struct PatchFactors { float edges[3] : SV_TessFactor; float inside : SV_InsideTessFactor; };
struct Surface { float4 position : SV_Position; float3 normal : NORMAL; };

ControlPoint VSMain(ControlPoint p) { return p; }

PatchFactors Factors(InputPatch<ControlPoint, 3> patch)
{
    PatchFactors f;
    for (int i = 0; i < 3; ++i)
        f.edges[i] = clamp(maxFactor / distance(eye, 0.5 * (patch[(i + 1) % 3].position + patch[(i + 2) % 3].position)), 1, maxFactor);
    f.inside = (f.edges[0] + f.edges[1] + f.edges[2]) / 3;
    return f;
}

[domain("tri")]
[partitioning("fractional_odd")]
[outputtopology("triangle_cw")]
[outputcontrolpoints(3)]
[patchconstantfunc("Factors")]
ControlPoint HSMain(InputPatch<ControlPoint, 3> patch, uint id : SV_OutputControlPointID) { return patch[id]; }

[domain("tri")]
Surface DSMain(PatchFactors factors, float3 bary : SV_DomainLocation, const OutputPatch<ControlPoint, 3> patch)
{
    Surface s;
    float3 position = patch[0].position * bary.x + patch[1].position * bary.y + patch[2].position * bary.z;
    s.normal = normalize(patch[0].normal * bary.x + patch[1].normal * bary.y + patch[2].normal * bary.z);
    s.position = mul(viewProjection, float4(position, 1));
    return s;
}

float4 PSMain(Surface s) : SV_Target { return float4(s.normal * 0.5 + 0.5, 1); }
