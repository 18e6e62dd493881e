// corpus: a push-constant variable whose name starts with the attribute's word, `push_constants`, as one collection
// names it in every file; glslc and glslangValidator build it (as a $Global uniform buffer), kiln failed with
// "block instance name redefinition" past the end of the file (its rewrite took the name for a second attribute)
// default: ok
// layout: scene texture 0.0, sceneSampler sampler 0.1
// stages: vertex=main_vs fragment=main_ps
struct PushConstantsData
{
    float2 inv_resolution;
    float exposure;
    uint flags;
};

[[vk::push_constant]] PushConstantsData push_constants;

[[vk::binding(0)]] Texture2D<float4> scene;
[[vk::binding(1)]] SamplerState sceneSampler;

float4 main_vs(uint vertex_id : SV_VertexID) : SV_Position
{
    const float2 uv = float2((vertex_id << 1) & 2, vertex_id & 2);
    return float4(uv * 2.0 - 1.0, 0.0, 1.0);
}

float4 main_ps(float4 position : SV_Position) : SV_Target
{
    const float2 uv = position.xy * push_constants.inv_resolution;
    float4 color = scene.Sample(sceneSampler, uv) * push_constants.exposure;
    if (push_constants.flags & 1u) color.rgb = color.rgb / (1.0 + color.rgb);
    return color;
}
