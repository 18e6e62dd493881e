// corpus: a pixel shader writing a RWTexture2D (u0) beside its cbuffer (b0)
// default: K1406
// option: {"shifts": [{"register": "u", "shift": 8}]}
// layout: Params uniform_buffer 0.0, velocityOut storage_image 0.8
// stages: vertex=VSMain fragment=PSMain
cbuffer Params : register(b0) { float4x4 previousViewProjection; };
RWTexture2D<float4> velocityOut : register(u0);

float4 VSMain(float4 position : POSITION) : SV_Position { return position; }

float4 PSMain(float4 position : SV_Position) : SV_Target
{
    float4 previous = mul(previousViewProjection, float4(position.xyz, 1.0));
    velocityOut[uint2(position.xy)] = float4(previous.xy / previous.w - position.xy, 0.0, 1.0);
    return previous;
}
