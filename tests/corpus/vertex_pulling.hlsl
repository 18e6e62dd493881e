// corpus: vertex pulling from a StructuredBuffer in the vertex stage, a texture in the pixel stage
// default: K1406
// option: {"shifts": [{"register": "s", "shift": 16}]}
// layout: vertices storage_buffer 0.0, baseColor texture 0.1, trilinear sampler 0.16
// stages: vertex=VSMain fragment=PSMain
struct Vertex { float3 position; float2 uv; };
StructuredBuffer<Vertex> vertices : register(t0);
Texture2D baseColor : register(t1);
SamplerState trilinear : register(s0);

struct Varyings { float4 position : SV_Position; float2 uv : TEXCOORD0; };

Varyings VSMain(uint vertexId : SV_VertexID)
{
    Vertex v = vertices[vertexId];
    Varyings o;
    o.position = float4(v.position, 1.0);
    o.uv = v.uv;
    return o;
}

float4 PSMain(Varyings i) : SV_Target { return baseColor.Sample(trilinear, i.uv); }
