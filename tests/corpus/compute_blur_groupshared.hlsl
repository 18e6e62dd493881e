// corpus: a D3D11-style compute blur: RWTexture2D output, Texture2D input, groupshared tile and barriers,
// [numthreads(8, 8, 1)], registers t0/u0/b0 each numbered from 0 (the u class shifted, as DXC users do)
// default: K1406
// option: {"shifts": [{"register": "u", "shift": 8}, {"register": "t", "shift": 16}]}
// layout: BlurParams uniform_buffer 0.0, result storage_image 0.8, source texture 0.16
// stages: compute=CSMain
Texture2D<float4> source : register(t0);
RWTexture2D<float4> result : register(u0);
cbuffer BlurParams : register(b0) { int2 size; float weights[3]; };

groupshared float4 tile[10][10];

[numthreads(8, 8, 1)]
void CSMain(uint3 id : SV_DispatchThreadID, uint3 local : SV_GroupThreadID, uint3 group : SV_GroupID)
{
    int2 origin = int2(group.xy) * 8 - 1;
    for (uint i = local.y * 8 + local.x; i < 100; i += 64) {
        int2 texel = clamp(origin + int2(i % 10, i / 10), int2(0, 0), size - 1);
        tile[i / 10][i % 10] = source.Load(int3(texel, 0));
    }
    GroupMemoryBarrierWithGroupSync();
    float4 sum = 0;
    for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x)
            sum += tile[local.y + 1 + y][local.x + 1 + x] * weights[abs(x)] * weights[abs(y)];
    if (all(int2(id.xy) < size)) result[id.xy] = sum;
}
