// corpus: a GPU-driven culling kernel: ByteAddressBuffer loads, RWByteAddressBuffer with InterlockedAdd for an
// append counter, [numthreads(64, 1, 1)], no registers (automatic binding)
// default: ok
// layout: bounds storage_buffer 0.0, visible storage_buffer 0.1, Culling uniform_buffer 0.2
// stages: compute=CullMain
ByteAddressBuffer bounds;
RWByteAddressBuffer visible;
cbuffer Culling { float4 planes[6]; uint objectCount; };

[numthreads(64, 1, 1)]
void CullMain(uint3 id : SV_DispatchThreadID)
{
    if (id.x >= objectCount) return;
    float4 sphere = asfloat(bounds.Load4(id.x * 16));
    bool inside = true;
    for (int p = 0; p < 6; ++p) inside = inside && dot(planes[p].xyz, sphere.xyz) + planes[p].w > -sphere.w;
    if (inside) {
        uint slot;
        visible.InterlockedAdd(0, 1u, slot);  // 1, an int, makes glslang 12 write an invalid AtomicIAdd (docs/bindings.md)
        visible.Store((slot + 1) * 4, id.x);
    }
}
