// corpus: HLSL 2021 (DXC -HV 2021) intrinsics replacing the vector ?: && ||: select(c, a, b), and(a, b), or(a, b)
// on vectors and scalars, in a tonemapping pass; glslang 12 and glslc reject them, kiln rewrites them
// (docs/bindings.md)
// default: K1406
// option: {"shifts": [{"register": "t", "shift": 2}, {"register": "s", "shift": 3}]}
// layout: Grade uniform_buffer 0.0, sceneHdr texture 0.2, pointClamp sampler 0.3
// stages: vertex=VSMain fragment=PSMain
cbuffer Grade : register(b0) { float3 clipColor; float exposure; float3 lift; uint flags; };
Texture2D<float3> sceneHdr : register(t0);
SamplerState pointClamp : register(s0);

struct FullscreenVaryings { float4 position : SV_Position; float2 uv : TEXCOORD0; };

FullscreenVaryings VSMain(uint vertexId : SV_VertexID)
{
    FullscreenVaryings o;
    o.uv = float2((vertexId << 1) & 2, vertexId & 2);
    o.position = float4(o.uv * float2(2, -2) + float2(-1, 1), 0, 1);
    return o;
}

float4 PSMain(FullscreenVaryings i) : SV_Target
{
    float3 hdr = sceneHdr.Sample(pointClamp, i.uv) * exposure;
    bool3 overexposed = hdr > 1.0;
    bool3 invalid = or(isnan(hdr), isinf(hdr));
    bool3 showClip = and(overexposed, (flags & 1u).xxx != 0);
    float3 mapped = hdr / (1.0 + hdr);
    mapped = select(invalid, float3(1, 0, 1), mapped);
    mapped = select(showClip, clipColor, mapped + lift);
    float alpha = select(and(flags > 1u, !any(invalid)), 0.5, 1.0);
    return float4(mapped, alpha);
}
