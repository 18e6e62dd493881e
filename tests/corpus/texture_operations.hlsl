// corpus: Shader Model 5 texture operations: SampleLevel, SampleGrad, SampleBias, Gather, Load with an offset,
// GetDimensions, a cube map and a 3D texture, one sampler shared by all (D3D11 registers, t and s in one space)
// default: K1406
// option: {"shifts": [{"register": "t", "shift": 8}, {"register": "s", "shift": 16}]}
// layout: albedo texture 0.8, environment texture 0.9, noiseVolume texture 0.10, trilinear sampler 0.16
// stages: vertex=VSMain fragment=PSMain
Texture2D<float4> albedo : register(t0);
TextureCube<float4> environment : register(t1);
Texture3D<float> noiseVolume : register(t2);
SamplerState trilinear : register(s0);

struct Varyings { float4 position : SV_Position; float2 uv : TEXCOORD0; float3 direction : TEXCOORD1; };

Varyings VSMain(uint id : SV_VertexID)
{
    Varyings output;
    float2 uv = float2((id << 1) & 2, id & 2);
    output.position = float4(uv * 2.0 - 1.0, 0.0, 1.0);
    output.uv = uv;
    output.direction = float3(uv, 1.0);
    return output;
}

float4 PSMain(Varyings input) : SV_Target
{
    float width, height;
    albedo.GetDimensions(width, height);
    float4 base = albedo.SampleLevel(trilinear, input.uv, log2(max(width, height)) - 1.0);
    base += albedo.SampleGrad(trilinear, input.uv, ddx(input.uv), ddy(input.uv));
    base += albedo.SampleBias(trilinear, input.uv, 0.5);
    float4 reds = albedo.GatherRed(trilinear, input.uv);
    float4 texel = albedo.Load(int3(input.position.xy, 0), int2(1, -1));
    float3 sky = environment.SampleLevel(trilinear, input.direction, 2.0).rgb;
    float noise = noiseVolume.Sample(trilinear, float3(input.uv, 0.5));
    return float4(base.rgb * 0.3 + sky * noise + texel.rgb, dot(reds, 0.25));
}
