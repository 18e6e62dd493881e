// corpus: a deferred lighting subpass as Vulkan renderers write it in HLSL: the G-buffer read through input
// attachments (SubpassInput, SubpassInputMS); they were in the SPIR-V and every target but in no reflection record,
// so a loader building its descriptor set layouts from the reflection missed them. GL and GL ES read them as
// samplers at gl_FragCoord, Metal as textures
// default: ok
// layout: gbufferAlbedo input_attachment 0.0, gbufferNormal input_attachment 0.1, gbufferDepth input_attachment 0.2, Lighting uniform_buffer 0.3
// stages: vertex=FullscreenVS fragment=LightingPS
[[vk::input_attachment_index(0)]] [[vk::binding(0)]] SubpassInput<float4> gbufferAlbedo;
[[vk::input_attachment_index(1)]] [[vk::binding(1)]] SubpassInput<float4> gbufferNormal;
[[vk::input_attachment_index(2)]] [[vk::binding(2)]] SubpassInputMS<float> gbufferDepth;

[[vk::binding(3)]] cbuffer Lighting { float4 lightDirection; float4 lightColor; };

float4 FullscreenVS(uint id : SV_VertexID) : SV_Position
{
    const float2 uv = float2((id << 1) & 2, id & 2);
    return float4(uv * 2.0 - 1.0, 0.0, 1.0);
}

float4 LightingPS() : SV_Target
{
    const float4 albedo = gbufferAlbedo.SubpassLoad();
    const float3 normal = normalize(gbufferNormal.SubpassLoad().xyz * 2.0 - 1.0);
    const float depth = gbufferDepth.SubpassLoad(0);
    const float lit = saturate(dot(normal, -lightDirection.xyz));
    return float4(albedo.rgb * lightColor.rgb * lit, depth < 1.0 ? 1.0 : 0.0);
}
