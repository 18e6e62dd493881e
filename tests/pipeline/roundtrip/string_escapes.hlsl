// printf strings reach the SPIR-V (OpString); glslang's preprocessed text printed them with their
// escapes applied, so "a\"b" came back as "a"b".
#define FORMAT "fmt \"%f\"\n"
float4 V(float4 p : POSITION) : SV_Position { return p; }
float4 F(float4 p : SV_Position) : SV_Target {
  printf("x=%f \"quoted\" \\ back\n", p.x);
  printf(FORMAT, p.y);
  printf("__kiln_lit_41 is an ordinary string here");
  printf("tab\there, no trouble");
  return p;
}
