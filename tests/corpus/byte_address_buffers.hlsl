// corpus: raw buffers: ByteAddressBuffer (t0) and RWByteAddressBuffer (u1) at distinct numbers
// default: ok
// layout: vertexData storage_buffer 0.0, counters storage_buffer 0.1
// stages: vertex=VSMain fragment=PSMain
ByteAddressBuffer vertexData : register(t0);
RWByteAddressBuffer counters : register(u1);

float4 VSMain(uint id : SV_VertexID) : SV_Position
{
    float3 p = asfloat(vertexData.Load3(id * 12));
    return float4(p, 1.0);
}

float4 PSMain() : SV_Target
{
    uint previous;
    counters.InterlockedAdd(0, 1u, previous);
    return float4(float(previous & 255u) / 255.0, 0.0, 0.0, 1.0);
}
