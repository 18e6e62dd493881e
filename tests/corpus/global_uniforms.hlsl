// corpus: loose global uniforms (the implicit $Global block), as in effect-file era shaders
// default: ok
// layout: $Global uniform_buffer 0.0
// stages: vertex=VSMain fragment=PSMain
float4x4 WorldViewProjection;
float4 MaterialColor;
float Time;

float4 VSMain(float4 position : POSITION) : SV_Position
{
    return mul(WorldViewProjection, position);
}

float4 PSMain() : SV_Target
{
    return MaterialColor * (0.5 + 0.5 * sin(Time));
}
