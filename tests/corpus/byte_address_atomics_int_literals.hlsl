// corpus: a histogram kernel that calls RWByteAddressBuffer's atomics with int literals and an int variable
// (`bins.InterlockedAdd(offset, 1)`), as DXC takes them (it converts to uint); glslang 12 passed the ints and its
// SPIR-V failed validation with no line ("AtomicIAdd: expected Value to be of type Result Type"); and
// InterlockedCompareStore, which glslang 12 dropped with only a warning (kiln makes it a CompareExchange)
// default: ok
// layout: image texture 0.0, bins storage_buffer 0.1
// stages: compute=Histogram
Texture2D<float4> image : register(t0);
RWByteAddressBuffer bins : register(u1);

[numthreads(16, 16, 1)]
void Histogram(uint3 id : SV_DispatchThreadID)
{
    const float luminance = dot(image[id.xy].rgb, float3(0.2126, 0.7152, 0.0722));
    const int bin = (int)(saturate(luminance) * 255.0);
    uint previous;
    bins.InterlockedAdd(bin * 4, 1, previous);
    bins.InterlockedMax(1024, bin);
    bins.InterlockedCompareExchange(1028, 0, 1, previous);
    bins.InterlockedOr(1032, 1 << (bin & 31));
    bins.InterlockedCompareStore(1036, 0, 1);
}
