// corpus: interpolation modifiers and system values: nointerpolation, noperspective, centroid, SV_VertexID,
// SV_InstanceID, SV_IsFrontFace, SV_Depth, clip() and discard, several render targets
// default: ok
// layout: DepthScale uniform_buffer 0.0
// stages: vertex=VSMain fragment=PSMain
cbuffer DepthScale { float depthScale; };

struct Varyings
{
    float4 position : SV_Position;
    nointerpolation uint instance : INSTANCE;
    noperspective float2 screenUV : TEXCOORD0;
    centroid float3 normal : NORMAL;
};

struct Targets
{
    float4 color : SV_Target0;
    float4 normal : SV_Target1;
    float depth : SV_Depth;
};

Varyings VSMain(float3 position : POSITION, float3 normal : NORMAL, uint vertex : SV_VertexID, uint instance : SV_InstanceID)
{
    Varyings output;
    output.position = float4(position + float3(instance, vertex & 1, 0) * 0.1, 1.0);
    output.instance = instance;
    output.screenUV = position.xy * 0.5 + 0.5;
    output.normal = normal;
    return output;
}

Targets PSMain(Varyings input, bool frontFace : SV_IsFrontFace)
{
    clip(input.screenUV.x - 0.01);
    if (input.instance > 7) discard;
    Targets output;
    float3 n = normalize(input.normal) * (frontFace ? 1.0 : -1.0);
    output.color = float4(input.screenUV, float(input.instance) / 8.0, 1.0);
    output.normal = float4(n * 0.5 + 0.5, 0.0);
    output.depth = input.position.z * depthScale;
    return output;
}
