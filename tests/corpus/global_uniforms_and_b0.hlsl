// corpus: $Global beside a cbuffer at b0, each used by one stage (glslang alone puts both at binding 0)
// default: ok
// option: {"global_uniform": {"binding": 7, "set": 0}}
// layout: PerObject uniform_buffer 0.0, $Global uniform_buffer 0.7
// stages: vertex=VSMain fragment=PSMain
cbuffer PerObject : register(b0) { float4x4 model; };
float4 tint;

float4 VSMain(float4 position : POSITION) : SV_Position { return mul(model, position); }
float4 PSMain() : SV_Target { return tint; }
