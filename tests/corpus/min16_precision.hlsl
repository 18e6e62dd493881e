// corpus: mobile-style min16float (RelaxedPrecision) math with loose $Global uniforms and one texture
// default: ok
// layout: $Global uniform_buffer 0.0, lut texture 0.1, lutSampler sampler 0.2
// stages: vertex=VSMain fragment=PSMain
float4x4 MVP;
min16float4 tint;
Texture2D lut;
SamplerState lutSampler;

float4 VSMain(float4 position : POSITION) : SV_Position { return mul(MVP, position); }

min16float4 PSMain(float4 position : SV_Position) : SV_Target
{
    min16float4 graded = (min16float4)lut.Sample(lutSampler, position.xy * 0.001);
    return graded * tint;
}
