// corpus: a luminance histogram/average reduction: groupshared partial sums, GroupMemoryBarrierWithGroupSync, and
// SM 6.0 wave intrinsics (WaveActiveSum, WavePrefixSum, WaveReadLaneFirst, WaveActiveMax, WaveIsFirstLane,
// WaveGetLaneIndex/Count) in compute; GLSL needs Vulkan semantics for subgroup arithmetic, so SPIR-V and MSL
// default: ok
// targets: spirv msl
// layout: ReduceParams uniform_buffer 0.0, hdrInput texture 0.1, averages storage_buffer 0.2
// stages: compute=ReduceMain
cbuffer ReduceParams { uint2 inputSize; float minLogLuminance; float logLuminanceRange; };
Texture2D<float4> hdrInput;
RWStructuredBuffer<float> averages;

groupshared float partialSums[32];
groupshared float partialMax[32];
groupshared float partialMedian[32];

[numthreads(256, 1, 1)]
void ReduceMain(uint3 id : SV_DispatchThreadID, uint index : SV_GroupIndex, uint3 group : SV_GroupID)
{
    uint2 texel = uint2(id.x % inputSize.x, id.x / inputSize.x);
    float luminance = dot(hdrInput.Load(int3(texel, 0)).rgb, float3(0.2126, 0.7152, 0.0722));
    float logLuminance = saturate((log2(max(luminance, 1e-4)) - minLogLuminance) / logLuminanceRange);

    float waveSum = WaveActiveSum(logLuminance);
    float waveMax = WaveActiveMax(logLuminance);
    float before = WavePrefixSum(logLuminance);  // running total of the lanes below this one
    uint waveIndex = index / WaveGetLaneCount();
    if (before < waveSum * 0.5 && before + logLuminance >= waveSum * 0.5) partialMedian[waveIndex] = logLuminance;
    if (WaveIsFirstLane()) {
        partialSums[waveIndex] = waveSum;
        partialMax[waveIndex] = waveMax;
    }
    GroupMemoryBarrierWithGroupSync();

    if (index < 32u) {
        uint waves = 256u / WaveGetLaneCount();
        float sum = index < waves ? partialSums[index] : 0.0;
        float total = WaveActiveSum(sum);
        float maximum = WaveActiveMax(index < waves ? partialMax[index] : 0.0);
        uint base = WaveReadLaneFirst(group.x * 3u);  // scalarized: the same for every lane
        if (WaveGetLaneIndex() == 0u) {
            averages[base] = total / 256.0;
            averages[base + 1u] = maximum;
            averages[base + 2u] = partialMedian[0];
        }
    }
}
