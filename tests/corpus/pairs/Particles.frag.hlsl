#pragma multi_compile _ PREMULTIPLIED
#include "../particles_stage_per_file.hlsl"

float4 main(ParticleVaryings i) : SV_Target
{
    float4 color = atlas.Sample(atlasSampler, i.uv) * i.color;
    color.a *= fade;
#ifdef PREMULTIPLIED
    color.rgb *= color.a;
#endif
    return color;
}
