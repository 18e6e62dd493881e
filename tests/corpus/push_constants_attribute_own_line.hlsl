// corpus: push constants as many DXC users format them: the attribute on a line of its own above the declaration,
// with a comment between; glslang 12 and glslc make the struct a member of the $Global uniform buffer without a
// word, and kiln saw only the one-line spelling before
// default: ok
// layout: baseColor texture 0.0, baseSampler sampler 0.1
// stages: vertex=VSMain fragment=PSMain
struct PushConstants
{
    float4x4 modelViewProjection;
    float4 baseColorFactor;
    uint materialIndex;
};

[[vk::push_constant]]
// one block per draw: Vulkan's vkCmdPushConstants
PushConstants pushConstants;

[[vk::binding(0)]] Texture2D baseColor;
[[vk::binding(1)]] SamplerState baseSampler;

struct VSOutput
{
    float4 position : SV_Position;
    [[vk::location(0)]] float2 uv : TEXCOORD0;
};

VSOutput VSMain([[vk::location(0)]] float3 position : POSITION, [[vk::location(1)]] float2 uv : TEXCOORD0)
{
    VSOutput output;
    output.position = mul(pushConstants.modelViewProjection, float4(position, 1.0));
    output.uv = uv;
    return output;
}

float4 PSMain(VSOutput input) : SV_Target
{
    return baseColor.Sample(baseSampler, input.uv) * pushConstants.baseColorFactor * float(pushConstants.materialIndex + 1);
}
