// Depth.hlsl with its fragment shader edited (it writes 1, not 0): the edit unit.capi's live-update test swaps in.
#pragma multi_compile _ ALPHA_CLIP

cbuffer PerDraw : register(b0) {
  float4x4 ObjectToClip;
  float4 Color;
};

float4 Vert(float3 positionOS : POSITION) : SV_Position { return mul(ObjectToClip, float4(positionOS, 1.0)); }

float4 Frag() : SV_Target {
#ifdef ALPHA_CLIP
  clip(Color.a - 0.5);
#endif
  return 1.0;
}
