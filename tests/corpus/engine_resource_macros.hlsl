// corpus: a render-pipeline library's resource macros (URP/HDRP style: TEXTURE2D, SAMPLER, CBUFFER_START,
// SAMPLE_TEXTURE2D), no registers, a material cbuffer and the per-draw $Global values
// default: ok
// layout: $Global uniform_buffer 0.0, UnityPerMaterial uniform_buffer 0.1, _BaseMap texture 0.2, sampler_BaseMap sampler 0.3
// stages: vertex=LitPassVertex fragment=LitPassFragment
#define TEXTURE2D(textureName) Texture2D textureName
#define SAMPLER(samplerName) SamplerState samplerName
#define CBUFFER_START(name) cbuffer name {
#define CBUFFER_END };
#define SAMPLE_TEXTURE2D(textureName, samplerName, coord2) textureName.Sample(samplerName, coord2)
#define TRANSFORM_TEX(tex, name) (tex.xy * name##_ST.xy + name##_ST.zw)
#define half4 float4
#define half3 float3

float4x4 unity_ObjectToWorld;
float4x4 unity_MatrixVP;

CBUFFER_START(UnityPerMaterial)
    float4 _BaseMap_ST;
    half4 _BaseColor;
    half _Cutoff;
CBUFFER_END

TEXTURE2D(_BaseMap);
SAMPLER(sampler_BaseMap);

struct Attributes { float4 positionOS : POSITION; float2 uv : TEXCOORD0; };
struct Varyings { float4 positionCS : SV_POSITION; float2 uv : TEXCOORD0; };

Varyings LitPassVertex(Attributes input)
{
    Varyings output;
    output.positionCS = mul(unity_MatrixVP, mul(unity_ObjectToWorld, float4(input.positionOS.xyz, 1.0)));
    output.uv = TRANSFORM_TEX(input.uv, _BaseMap);
    return output;
}

half4 LitPassFragment(Varyings input) : SV_Target
{
    half4 color = SAMPLE_TEXTURE2D(_BaseMap, sampler_BaseMap, input.uv) * _BaseColor;
    clip(color.a - _Cutoff);
    return color;
}
