// corpus: engine-generated style: no registers at all, names like _MainTex / sampler_MainTex
// default: ok
// layout: $Global uniform_buffer 0.0, _MainTex texture 0.1, sampler_MainTex sampler 0.2
// stages: vertex=vert fragment=frag
float4x4 unity_ObjectToWorld;
float4x4 unity_MatrixVP;
float4 _Color;
Texture2D _MainTex;
SamplerState sampler_MainTex;

struct appdata { float4 vertex : POSITION; float2 uv : TEXCOORD0; };
struct v2f { float4 pos : SV_POSITION; float2 uv : TEXCOORD0; };

v2f vert(appdata v)
{
    v2f o;
    o.pos = mul(unity_MatrixVP, mul(unity_ObjectToWorld, v.vertex));
    o.uv = v.uv;
    return o;
}

float4 frag(v2f i) : SV_Target { return _MainTex.Sample(sampler_MainTex, i.uv) * _Color; }
