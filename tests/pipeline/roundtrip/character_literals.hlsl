// Character literals: glslang reads 'A' as the integer 65; its preprocessed text printed A, which
// compiled silently to the constant A below. Apostrophes in comments (don't, Karis' fit) are not literals.
#pragma multi_compile _ USE_MACRO
static const int A = 5;
static const int B = 6;
#define LETTER 'B'
#if 'A' == 65
static const int kConditionSeen = 1;
#else
static const int kConditionSeen = 0;
#endif
float4 V(float4 p : POSITION) : SV_Position { return p; }
float4 F() : SV_Target {
  int c = 'A';
#ifdef USE_MACRO
  c += LETTER;
#endif
  return float4(c, kConditionSeen, A, B);
}
