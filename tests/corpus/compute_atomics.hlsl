// corpus: a light-binning kernel: RWStructuredBuffer (u0) and RWByteAddressBuffer (u1) updated with Interlocked*
// atomics (Add, Min, Max, Or, CompareExchange, Exchange), a read-only StructuredBuffer (t0), no cbuffer
// default: ok
// layout: lights storage_buffer 0.0, tileLightCounts storage_buffer 0.1, tileBounds storage_buffer 0.2
// stages: compute=BinLights
struct Light { float3 position; float radius; uint tileMask; uint padding0, padding1, padding2; };
StructuredBuffer<Light> lights : register(t0);
RWStructuredBuffer<uint> tileLightCounts : register(u1);
RWByteAddressBuffer tileBounds : register(u2);

[numthreads(64, 1, 1)]
void BinLights(uint3 id : SV_DispatchThreadID)
{
    Light light = lights[id.x];
    uint tile = light.tileMask & 255u;
    uint previous;
    InterlockedAdd(tileLightCounts[tile], 1u, previous);
    InterlockedMax(tileLightCounts[256 + tile], asuint(light.radius));
    InterlockedOr(tileLightCounts[512 + (tile >> 5)], 1u << (tile & 31u));
    tileBounds.InterlockedMin(tile * 8u, asuint(light.position.z));
    tileBounds.InterlockedMax(tile * 8u + 4u, asuint(light.position.z));
    uint original;
    tileBounds.InterlockedCompareExchange(2048u + tile * 4u, 0u, id.x + 1u, original);
    if (original != 0u) tileBounds.InterlockedExchange(4096u + tile * 4u, previous, original);
}
