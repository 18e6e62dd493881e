// The C API tests' second shader (texels.pack.json): the resource kinds of their own since issue 62, a uniform texel
// buffer, a storage texel buffer and an input attachment with its index.
Buffer<float4> LightColors : register(t0);
RWBuffer<uint> Counters : register(u1);
[[vk::input_attachment_index(2)]] [[vk::binding(3)]] SubpassInput<float4> GBufferAlbedo;

float4 Vert(float3 positionOS : POSITION) : SV_Position { return float4(positionOS, 1.0); }

float4 Frag(float4 positionCS : SV_Position) : SV_Target {
  Counters[uint(positionCS.x)] = 1u;
  return LightColors[uint(positionCS.y)] * GBufferAlbedo.SubpassLoad();
}
