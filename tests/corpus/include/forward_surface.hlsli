// Shared forward-surface implementation: the including pass file declares its resources and SURFACE_* settings,
// this file supplies the vertex and pixel entry points (the "pass template" layout many engines use).
#ifndef SURFACE_UV_SCALE
#define SURFACE_UV_SCALE 1.0
#endif

struct SurfaceVaryings { float4 position : SV_Position; float3 normal : NORMAL; float2 uv : TEXCOORD0; };

SurfaceVaryings SurfaceVertex(float3 position : POSITION, float3 normal : NORMAL, float2 uv : TEXCOORD0)
{
    SurfaceVaryings o;
    o.position = mul(objectToClip, float4(position, 1.0));
    o.normal = normal;
    o.uv = uv * SURFACE_UV_SCALE;
    return o;
}

float4 SurfaceFragment(SurfaceVaryings i) : SV_Target
{
    float3 albedo = surfaceAlbedo.Sample(surfaceSampler, i.uv).rgb;
    return float4(albedo * (0.2 + 0.8 * saturate(dot(normalize(i.normal), sunDirection))), 1.0);
}
