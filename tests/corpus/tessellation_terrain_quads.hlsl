// corpus: terrain tessellation on quad patches: a hull shader with integer partitioning and a patch constant
// function picking edge factors by distance, a domain shader displacing by a heightmap (SampleLevel) bilinearly
// across the four control points; D3D11 registers b0/t0/s0 each from 0; no tessellation stages in Metal here
// default: K1406
// option: {"shifts": [{"register": "t", "shift": 4}, {"register": "s", "shift": 8}]}
// targets: spirv glsl gles
// layout: Terrain uniform_buffer 0.0, heightMap texture 0.4, heightSampler sampler 0.8
// stages: vertex=VSMain hull=HSMain domain=DSMain fragment=PSMain
cbuffer Terrain : register(b0) { float4x4 viewProjection; float3 cameraPosition; float heightScale; float tessellationDistance; };
Texture2D<float> heightMap : register(t0);
SamplerState heightSampler : register(s0);

struct PatchPoint { float3 position : POSITION; float2 uv : TEXCOORD0; };
struct QuadFactors { float edges[4] : SV_TessFactor; float inside[2] : SV_InsideTessFactor; };
struct TerrainVertex { float4 position : SV_Position; float2 uv : TEXCOORD0; float height : TEXCOORD1; };

PatchPoint VSMain(PatchPoint p) { return p; }

float EdgeFactor(float3 a, float3 b)
{
    float d = distance(cameraPosition, 0.5 * (a + b));
    return clamp(64.0 * (1.0 - saturate(d / tessellationDistance)), 1.0, 64.0);
}

QuadFactors QuadConstants(InputPatch<PatchPoint, 4> patch)
{
    QuadFactors f;
    f.edges[0] = EdgeFactor(patch[0].position, patch[2].position);
    f.edges[1] = EdgeFactor(patch[0].position, patch[1].position);
    f.edges[2] = EdgeFactor(patch[1].position, patch[3].position);
    f.edges[3] = EdgeFactor(patch[2].position, patch[3].position);
    f.inside[0] = max(f.edges[1], f.edges[3]);
    f.inside[1] = max(f.edges[0], f.edges[2]);
    return f;
}

[domain("quad")]
[partitioning("integer")]
[outputtopology("triangle_ccw")]
[outputcontrolpoints(4)]
[patchconstantfunc("QuadConstants")]
PatchPoint HSMain(InputPatch<PatchPoint, 4> patch, uint id : SV_OutputControlPointID) { return patch[id]; }

[domain("quad")]
TerrainVertex DSMain(QuadFactors factors, float2 uv : SV_DomainLocation, const OutputPatch<PatchPoint, 4> patch)
{
    float3 position = lerp(lerp(patch[0].position, patch[1].position, uv.x), lerp(patch[2].position, patch[3].position, uv.x), uv.y);
    float2 texcoord = lerp(lerp(patch[0].uv, patch[1].uv, uv.x), lerp(patch[2].uv, patch[3].uv, uv.x), uv.y);
    TerrainVertex v;
    v.height = heightMap.SampleLevel(heightSampler, texcoord, 0.0);
    position.y += v.height * heightScale;
    v.position = mul(viewProjection, float4(position, 1.0));
    v.uv = texcoord;
    return v;
}

float4 PSMain(TerrainVertex v) : SV_Target { return float4(lerp(float3(0.2, 0.4, 0.1), float3(0.9, 0.9, 0.95), v.height), 1.0); }
