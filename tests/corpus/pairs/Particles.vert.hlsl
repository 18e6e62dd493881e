#pragma multi_compile _ SOFT_SIZE
#include "../particles_stage_per_file.hlsl"

ParticleVaryings main(uint vertexId : SV_VertexID, uint instanceId : SV_InstanceID)
{
    ParticleData p = particles[instanceId];
    float2 corner = float2(vertexId & 1u, vertexId >> 1) * 2.0 - 1.0;
    float size = p.size;
#ifdef SOFT_SIZE
    size *= 0.75 + 0.25 * sin(time * 4.0 + float(instanceId));
#endif
    float3 world = p.position + (cameraRight * corner.x + cameraUp * corner.y) * size;
    ParticleVaryings o;
    o.position = mul(viewProjection, float4(world, 1.0));
    o.color = p.color;
    o.uv = p.atlasRect.xy + (corner * 0.5 + 0.5) * p.atlasRect.zw;
    return o;
}
