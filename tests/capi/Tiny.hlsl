// The C API tests' shader: a few keyword groups of each kind, a constant buffer, a texture and its sampler, push
// constants and two vertex inputs; small enough to build in seconds.
#pragma multi_compile _ FOG
#pragma multi_compile QUALITY_LOW QUALITY_HIGH
#pragma multi_compile_fragment _ TINT

cbuffer PerDraw : register(b0) {
  float4x4 ObjectToClip;
  float4 Color;
};
Texture2D Albedo : register(t1);
SamplerState AlbedoSampler : register(s2);

struct PushData {
  float4 Tint;
};
[[vk::push_constant]] ConstantBuffer<PushData> Push;

struct Attributes {
  float3 positionOS : POSITION;
  float2 uv : TEXCOORD0;
};
struct Varyings {
  float4 positionCS : SV_Position;
  float2 uv : TEXCOORD0;
};

Varyings Vert(Attributes input) {
  Varyings output;
  output.positionCS = mul(ObjectToClip, float4(input.positionOS, 1.0));
  output.uv = input.uv;
  return output;
}

float4 Frag(Varyings input) : SV_Target {
  float4 color = Color * Albedo.Sample(AlbedoSampler, input.uv);
#ifdef QUALITY_HIGH
  color.rgb = sqrt(color.rgb);
#endif
#ifdef FOG
  color.rgb = lerp(color.rgb, float3(0.5, 0.5, 0.5), 0.25);
#endif
#ifdef TINT
  color *= Push.Tint;
#endif
  return color;
}
