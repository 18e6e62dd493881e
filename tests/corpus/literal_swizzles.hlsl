// corpus: swizzles of scalar literals as DXC takes them (`0.xxxx`, `1.0.xxx`, `0.5f.rr`, `0.xx`) in a deferred
// lighting resolve, resources without registers; glslang 12 and glslc reject the integer ones (`0.` lexes as a
// float, leaving `xxxx` a word), kiln rewrites them all to `(0).xxxx` (docs/bindings.md)
// default: ok
// layout: gbufferNormal texture 0.0, gbufferAlbedo texture 0.1, LightData uniform_buffer 0.2, pointSampler sampler 0.3
// stages: vertex=VSMain fragment=PSMain
Texture2D gbufferNormal;
Texture2D gbufferAlbedo;
cbuffer LightData { float3 lightDirection; float ambient; float3 lightColor; float pad; };
SamplerState pointSampler;

struct Quad { float4 position : SV_Position; float2 uv : TEXCOORD0; };

Quad VSMain(float2 position : POSITION)
{
    Quad q;
    q.position = float4(position, 0.xx);
    q.position.w = 1;
    q.uv = position * 0.5f.rr + 0.5;
    return q;
}

float4 PSMain(Quad q) : SV_Target
{
    float4 normalSample = gbufferNormal.Sample(pointSampler, q.uv);
    if (normalSample.w == 0) return 0.xxxx;
    float3 n = normalize(normalSample.xyz * 2.0 - 1.0.xxx);
    float3 albedo = gbufferAlbedo.Sample(pointSampler, q.uv).rgb;
    float3 lit = albedo * (lightColor * saturate(dot(n, -lightDirection)) + ambient.xxx);
    return float4(min(lit, 1.0.xxx), 1);
}
