// corpus: typed buffers: a Buffer<float4> (t0) read in the vertex stage, a RWBuffer<uint> (u0) written in the pixel stage
// default: K1406
// option: {"shifts": [{"register": "u", "shift": 4}]}
// layout: instanceOffsets uniform_texel_buffer 0.0, pixelCounts storage_texel_buffer 0.4
// stages: vertex=VSMain fragment=PSMain
Buffer<float4> instanceOffsets : register(t0);
RWBuffer<uint> pixelCounts : register(u0);

float4 VSMain(float4 position : POSITION, uint instance : SV_InstanceID) : SV_Position
{
    return position + instanceOffsets.Load(instance);
}

float4 PSMain(float4 position : SV_Position) : SV_Target
{
    InterlockedAdd(pixelCounts[uint(position.x) & 63u], 1u);
    return 1.0;
}
