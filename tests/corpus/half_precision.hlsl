// corpus: explicit 16-bit types (-enable-16bit-types style, spelled `half`) in the shading math
// default: K1406
// option: {"shifts": [{"register": "t", "shift": 16}, {"register": "s", "shift": 32}]}
// layout: Tonemap uniform_buffer 0.0, hdrColor texture 0.16, pointSampler sampler 0.32
// stages: vertex=VSMain fragment=PSMain
cbuffer Tonemap : register(b0) { float exposure; };
Texture2D<float4> hdrColor : register(t0);
SamplerState pointSampler : register(s0);

float4 VSMain(float4 position : POSITION) : SV_Position { return position; }

half3 ReinhardTonemap(half3 color) { return color / (half3(1.0, 1.0, 1.0) + color); }

float4 PSMain(float4 position : SV_Position) : SV_Target
{
    half gain = (half)exposure;  // glslang 12 takes `half`, not `float16_t` (docs/bindings.md)
    half3 color = half3(hdrColor.Sample(pointSampler, position.xy).rgb) * gain;
    return float4(ReinhardTonemap(color), 1.0);
}
