// corpus: stage-per-file, as glslc and DXC projects lay them out: pairs/Water.vert.hlsl and pairs/Water.frag.hlsl,
// each with its own `main` and its own keyword, sharing this file's declarations (D3D registers with a space)
// default: K1406
// option: {"shifts": [{"register": "t", "shift": 8, "space": 1}, {"register": "s", "shift": 16, "space": 1}]}
// layout: WaterParams uniform_buffer 1.0, normalMap texture 1.8, linearWrap sampler 1.16
// stages: vertex=pairs/Water.vert.hlsl:main fragment=pairs/Water.frag.hlsl:main
#pragma once
cbuffer WaterParams : register(b0, space1) { float4x4 viewProjection; float3 deepColor; float time; };
Texture2D<float4> normalMap : register(t0, space1);
SamplerState linearWrap : register(s0, space1);

struct WaterVaryings { float4 position : SV_Position; float2 uv : TEXCOORD0; float3 world : TEXCOORD1; };
