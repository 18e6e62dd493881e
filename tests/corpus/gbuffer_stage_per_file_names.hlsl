// corpus: stage-per-file written by two people: pairs/GBuffer.vert.hlsl names the per-object constants
// `PerObject` with two matrices, pairs/GBuffer.frag.hlsl names the same register `ObjectConstants` and declares
// only the first matrix, and the textures only where they are read. One pipeline layout serves it, as Vulkan's
// rule says (descriptor type, count, dimension per binding; names and trailing members may differ)
// default: ok
// layout: FrameConstants uniform_buffer 0.0, PerObject uniform_buffer 0.1, albedoMap texture 0.2, normalMap texture 0.3, gbufferSampler sampler 0.4
// stages: vertex=pairs/GBuffer.vert.hlsl:main fragment=pairs/GBuffer.frag.hlsl:main
#pragma once
cbuffer FrameConstants : register(b0) { float4x4 viewProjection; float3 cameraPosition; float time; };
