// corpus: compute-style data in a pixel shader: a read-only StructuredBuffer (t0) and a RWStructuredBuffer (u0)
// default: K1406
// option: {"shifts": [{"register": "u", "shift": 32}]}
// layout: lights storage_buffer 0.0, histogram storage_buffer 0.32
// stages: vertex=VSMain fragment=PSMain
struct Light { float3 position; float range; float3 color; float intensity; };
StructuredBuffer<Light> lights : register(t0);
RWStructuredBuffer<uint> histogram : register(u0);

float4 VSMain(float4 position : POSITION) : SV_Position { return position; }

float4 PSMain(float4 position : SV_Position) : SV_Target
{
    Light light = lights[0];
    float attenuation = saturate(1.0 - distance(position.xyz, light.position) / light.range);
    uint bucket = min(uint(attenuation * 15.0), 15u);
    InterlockedAdd(histogram[bucket], 1u);
    return float4(light.color * light.intensity * attenuation, 1.0);
}
