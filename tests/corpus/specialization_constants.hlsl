// corpus: a specialization constant ([[vk::constant_id]]) choosing a loop count, one cbuffer
// default: ok
// layout: Blur uniform_buffer 0.0, source texture 0.1, clampSampler sampler 0.2
// stages: vertex=VSMain fragment=PSMain
[[vk::constant_id(0)]] const int kTaps = 4;
cbuffer Blur : register(b0) { float2 texelStep; };
Texture2D source : register(t1);
SamplerState clampSampler : register(s2);

float4 VSMain(float4 position : POSITION) : SV_Position { return position; }

float4 PSMain(float4 position : SV_Position) : SV_Target
{
    float4 sum = 0;
    for (int i = 0; i < kTaps; ++i) sum += source.Sample(clampSampler, position.xy + texelStep * i);
    return sum / kTaps;
}
