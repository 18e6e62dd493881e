// Macro expansion that the preprocessed text must keep token for token.
#pragma multi_compile _ WIDE
#define NEG -
#define PLUS +
#define CAT(a, b) a##b
#define TWICE(x) ((x) + (x))
#define LONG_SUM(a, b) \
  ((a) * 2 + \
   (b))
float4 V(float4 p : POSITION) : SV_Position { return p; }
float4 F(float4 p : SV_Position) : SV_Target {
  float CAT(va, lue) = -NEG p.x;
  float other = 1 PLUS+ p.y;
#ifdef WIDE
  value = TWICE(value);
#endif
  return float4(value, other, LONG_SUM(p.z, p.w), 1.5e-3);
}
