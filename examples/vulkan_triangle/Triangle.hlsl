// The example's shader: one triangle in a constant colour; INVERT inverts it.
#pragma multi_compile _ INVERT

cbuffer Frame : register(b0) {
  float4 Color;
  float4 Offset;  // xy: added to every vertex position, in clip space
};

float4 Vert(float2 positionCS : POSITION) : SV_Position { return float4(positionCS + Offset.xy, 0.0, 1.0); }

float4 Frag() : SV_Target {
#ifdef INVERT
  return float4(1.0 - Color.rgb, Color.a);
#else
  return Color;
#endif
}
// SPDX-License-Identifier: Apache-2.0
