#pragma multi_compile _ WAVES
#include "../water_stage_per_file.hlsl"

WaterVaryings main(float3 position : POSITION, float2 uv : TEXCOORD0)
{
    WaterVaryings o;
    float3 world = position;
#ifdef WAVES
    world.y += 0.1 * sin(world.x * 3.0 + time);
#endif
    o.position = mul(viewProjection, float4(world, 1.0));
    o.uv = uv;
    o.world = world;
    return o;
}
