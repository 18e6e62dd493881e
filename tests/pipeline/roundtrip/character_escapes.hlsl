// Escaped character literals: glslang printed '\n' as a raw newline (shifting every line after it)
// and '\'' as a lone quote.
float4 V(float4 p : POSITION) : SV_Position { return p; }
float4 F() : SV_Target {
  int newline = '\n';
  int quote = '\'';
  int backslash = '\\';
  int tab = '\t';
  return float4(newline, quote, backslash, tab);
}
