#pragma multi_compile _ FOAM
#include "../water_stage_per_file.hlsl"

float4 main(WaterVaryings i) : SV_Target
{
    float3 n = normalize(normalMap.Sample(linearWrap, i.uv + time * 0.01).xyz * 2.0 - 1.0);
    float3 color = deepColor * (0.5 + 0.5 * n.y);
#ifdef FOAM
    color += saturate(i.world.y * 8.0);
#endif
    return float4(color, 1.0);
}
