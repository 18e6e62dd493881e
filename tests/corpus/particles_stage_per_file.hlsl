// corpus: stage-per-file with Vulkan-first declarations: pairs/Particles.vert.hlsl pulls billboard corners from a
// StructuredBuffer and pairs/Particles.frag.hlsl samples an atlas, each `main` including this file's
// [[vk::binding]] declarations (set 0 frame data, set 1 material) and its own keyword
// default: ok
// layout: Frame uniform_buffer 0.0, particles storage_buffer 0.1, atlas texture 1.0, atlasSampler sampler 1.1
// stages: vertex=pairs/Particles.vert.hlsl:main fragment=pairs/Particles.frag.hlsl:main
#pragma once
struct ParticleData { float3 position; float size; float4 color; float4 atlasRect; };

[[vk::binding(0, 0)]] cbuffer Frame { float4x4 viewProjection; float3 cameraRight; float time; float3 cameraUp; float fade; };
[[vk::binding(1, 0)]] StructuredBuffer<ParticleData> particles;
[[vk::binding(0, 1)]] Texture2D atlas;
[[vk::binding(1, 1)]] SamplerState atlasSampler;

struct ParticleVaryings { float4 position : SV_Position; float4 color : COLOR0; float2 uv : TEXCOORD0; };
