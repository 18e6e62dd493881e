// 1.#INF is HLSL's spelling of +infinity; glslang's preprocessed text printed 1.INF.
#define MY_INF 1.#INF
float4 V(float4 p : POSITION) : SV_Position { return p; }
float4 F(float4 p : SV_Position) : SV_Target {
  float far = 1.#INF;
  float lowest = -1.#INF;
  return float4(min(p.x, far), max(p.y, lowest), MY_INF, 0);
}
