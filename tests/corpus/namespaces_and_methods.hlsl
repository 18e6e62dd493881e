// corpus: library code organised the C++ way: namespaces, struct member functions, typedefs, inline helpers
// default: ok
// layout: Lighting uniform_buffer 0.0
// stages: vertex=VSMain fragment=PSMain
typedef float3 Color;

// glslang 12 takes functions in a namespace but not types (`Shading::DirectionalLight` is an unknown variable):
// engines that build with it keep their structs at file scope.
struct DirectionalLight
{
    float3 direction;
    Color radiance;
    Color Lambert(float3 normal) { return radiance * saturate(dot(normal, -direction)); }
};

namespace Shading
{
    inline float Square(float x) { return x * x; }
    namespace Detail { float Cube(float x) { return x * x * x; } }
}

cbuffer Lighting : register(b0)
{
    float3 lightDirection;
    float lightIntensity;
    float3 lightColor;
    float roughness;
};

struct Varyings { float4 position : SV_Position; float3 normal : NORMAL; };

Varyings VSMain(float3 position : POSITION, float3 normal : NORMAL)
{
    Varyings output;
    output.position = float4(position, 1.0);
    output.normal = normal;
    return output;
}

float4 PSMain(Varyings input) : SV_Target
{
    DirectionalLight light;
    light.direction = lightDirection;
    light.radiance = lightColor * lightIntensity;
    Color diffuse = light.Lambert(normalize(input.normal));
    return float4(diffuse * (1.0 - Shading::Square(roughness)) + Shading::Detail::Cube(roughness), 1.0);
}
