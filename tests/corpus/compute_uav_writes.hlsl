// corpus: a D3D11-style compute pass writing three kinds of typed UAV: RWTexture2D (u0), RWTexture3D (u1), RWBuffer
// (u2), reading a Texture2D at t0 and a cbuffer at b0, every class numbered from 0 (the u class shifted)
// default: K1406
// option: {"shifts": [{"register": "u", "shift": 16}]}
// layout: VolumeParams uniform_buffer 0.0, sceneColor texture 0.1, outputColor storage_image 0.16, froxels storage_image 0.17, tileCounts storage_texel_buffer 0.18
// stages: compute=CSMain
cbuffer VolumeParams : register(b0) { uint2 outputSize; uint froxelDepth; float density; };
Texture2D<float4> sceneColor : register(t1);
RWTexture2D<float4> outputColor : register(u0);
RWTexture3D<float> froxels : register(u1);
RWBuffer<uint> tileCounts : register(u2);

[numthreads(8, 8, 1)]
void CSMain(uint3 id : SV_DispatchThreadID, uint3 group : SV_GroupID)
{
    if (any(id.xy >= outputSize)) return;
    float4 color = sceneColor.Load(int3(id.xy, 0));
    float fog = 0.0;
    for (uint z = 0; z < froxelDepth; ++z) {
        float slice = density * (1.0 - float(z) / float(froxelDepth));
        froxels[uint3(id.xy, z)] = slice;
        fog += slice;
    }
    outputColor[id.xy] = lerp(color, float4(0.5, 0.6, 0.7, 1.0), saturate(fog));
    if (fog > 0.5) InterlockedAdd(tileCounts[group.y * 64u + group.x], 1u);
}
