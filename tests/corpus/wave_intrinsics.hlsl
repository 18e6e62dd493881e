// corpus: Shader Model 6 wave and quad intrinsics in a fragment shader (SPIR-V 1.3 subgroup operations). SPIRV-Cross
// writes subgroup arithmetic for GLSL only with Vulkan semantics, and MSL 2.1 has no lane count in fragment
// shaders (WaveActiveCountBits, WaveGetLaneCount), so the pack ships SPIR-V and MSL (docs/bindings.md)
// default: ok
// targets: spirv msl
// layout: Exposure uniform_buffer 0.0
// stages: vertex=VSMain fragment=PSMain
cbuffer Exposure : register(b0) { float exposure; };

float4 VSMain(float4 position : POSITION) : SV_Position { return position; }

float4 PSMain(float4 position : SV_Position) : SV_Target
{
    float luminance = position.x * exposure;
    float waveTotal = WaveActiveSum(luminance);
    float neighbour = QuadReadAcrossX(luminance);
    bool first = WaveIsFirstLane();
    return float4(waveTotal, neighbour, first ? 1.0 : 0.0, 1.0);
}
