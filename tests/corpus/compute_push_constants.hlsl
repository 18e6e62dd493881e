// corpus: a compute dispatch parameterised by push constants in the ConstantBuffer<T> spelling
// (`[[vk::push_constant]] ConstantBuffer<DispatchArgs> args;`), writing a RWStructuredBuffer and reading a
// ByteAddressBuffer, no registers (automatic binding)
// default: ok
// layout: particlesIn storage_buffer 0.0, particlesOut storage_buffer 0.1
// stages: compute=Integrate
struct DispatchArgs { float deltaTime; uint particleCount; float2 padding; float4 gravity; };
[[vk::push_constant]] ConstantBuffer<DispatchArgs> args;

struct Particle { float4 position; float4 velocity; };
ByteAddressBuffer particlesIn;
RWStructuredBuffer<Particle> particlesOut;

[numthreads(128, 1, 1)]
void Integrate(uint3 id : SV_DispatchThreadID)
{
    if (id.x >= args.particleCount) return;
    Particle p;
    p.position = asfloat(particlesIn.Load4(id.x * 32u));
    p.velocity = asfloat(particlesIn.Load4(id.x * 32u + 16u)) + args.gravity * args.deltaTime;
    p.position.xyz += p.velocity.xyz * args.deltaTime;
    particlesOut[id.x] = p;
}
