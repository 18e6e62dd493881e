// corpus: a pass file that declares its resources and settings, then ends with `#include` of the shared
// implementation (include/forward_surface.hlsli, which holds the entry points) on a last line without a newline;
// D3D12 registers in space 2 for the material, the per-object cbuffer in space 0
// default: K1406
// option: {"shifts": [{"register": "s", "shift": 4, "space": 2}]}
// layout: PerObject uniform_buffer 0.0, surfaceAlbedo texture 2.0, surfaceSampler sampler 2.4
// stages: vertex=SurfaceVertex fragment=SurfaceFragment
cbuffer PerObject : register(b0) { float4x4 objectToClip; float3 sunDirection; };
Texture2D surfaceAlbedo : register(t0, space2);
SamplerState surfaceSampler : register(s0, space2);

#define SURFACE_UV_SCALE 4.0
#include "include/forward_surface.hlsli"