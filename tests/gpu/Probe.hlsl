// Probe shaders: evaluate shaderlib functions on the GPU, one input record per pixel, one float4 per pixel.
// Driven by tests/gpu/lavapipe.cpp; each PROBE_* define selects what Evaluate() computes. Every probe calls
// the library's functions exactly as the Forward pass does (same guards before the call, nothing extra),
// except PROBE_TEXTBOOK, the unguarded kernel that proves the stress harness can see failures.
//
// Record layout: a, b, c, d (float4 each), meaning per probe as documented below.
// The study's smaller DFG tables (SampleDFG maps coordinates for the table's size).
#if defined(PROBE_DFG_16)
#define KILN_DFG_SIZE 16.0
#elif defined(PROBE_DFG_32)
#define KILN_DFG_SIZE 32.0
#endif
#include "Lighting.hlsl"
#include "Tonemap.hlsl"
#include "Fog.hlsl"

#define PROBE_WIDTH 128u  // kiln::gpu::kProbeWidth

struct ProbeInput
{
    float4 a;
    float4 b;
    float4 c;
    float4 d;
};

[[vk::binding(20, 0)]] StructuredBuffer<ProbeInput> gProbeInputs : register(t20);
#if defined(PROBE_TABLE) || defined(PROBE_USES_TABLE)
[[vk::binding(21, 0)]] Texture2D gProbeTable : register(t21);
[[vk::binding(22, 0)]] SamplerState gProbeSampler : register(s22);
#endif

float4 ProbeVertex(uint id : SV_VertexID) : SV_Position
{
    float2 uv = float2((float)((id << 1) & 2u), (float)(id & 2u));
    return float4(uv * 2.0 - 1.0, 0.0, 1.0);
}

// Shared decoding of the BRDF-term records: a = (perceptual roughness, NoV, NoL, NoH), b = (LoH, f0, anisotropy, phi).
struct TermInputs
{
    real perceptualRoughness;  // clamped, as ShadingData holds it
    real alpha;
    real NoV;                  // floored at MIN_N_DOT_V, as PrepareShading does
    real NoL;
    real NoH;
    real oneMinusNoHSquared;
    real LoH;
    real f0;
};

TermInputs DecodeTerms(ProbeInput p)
{
    TermInputs t;
    t.perceptualRoughness = ClampedPerceptualRoughness((real)p.a.x);
    t.alpha = PerceptualRoughnessToAlpha((real)p.a.x);
    t.NoV = (real)max(p.a.y, MIN_N_DOT_V);
    t.NoL = (real)saturate(p.a.z);
    t.NoH = (real)saturate(p.a.w);
    // |N x H|^2 as SpecularDV forms it (a cross product, exact near NoH = 1), here from NoH in fp32.
    t.oneMinusNoHSquared = (real)max((1.0 - p.a.w) * (1.0 + p.a.w), 0.0);
    t.LoH = (real)saturate(p.b.x);
    t.f0 = (real)p.b.y;
    return t;
}

#if defined(PROBE_SPECULAR)
// D_GGX, V_SmithGGXCorrelated, V_SmithGGXCorrelated_Fast, F_Schlick (multiply chain).
float4 Evaluate(ProbeInput p)
{
    TermInputs t = DecodeTerms(p);
    return float4(D_GGX(t.NoH, t.alpha, t.oneMinusNoHSquared), V_SmithGGXCorrelated(t.NoV, t.NoL, t.alpha),
                  V_SmithGGXCorrelated_Fast(t.NoV, t.NoL, t.alpha), F_Schlick(t.f0, (real)1.0, t.LoH));
}
#elif defined(PROBE_SPECULAR_MORE)
// V_SmithGGX_Separable, F_Schlick_Pow, D_GGX_Anisotropic, V_SmithGGXCorrelated_Anisotropic; the tangent frame
// is rotated by phi; at and ab are formed as PrepareShading forms them.
float4 Evaluate(ProbeInput p)
{
    TermInputs t = DecodeTerms(p);
    real anisotropy = (real)clamp(p.b.z, -1.0, 1.0);
    real minAlpha = (real)(MIN_PERCEPTUAL_ROUGHNESS * MIN_PERCEPTUAL_ROUGHNESS);
    real at = (real)max(t.alpha * ((real)1.0 + anisotropy), minAlpha);
    real ab = (real)max(t.alpha * ((real)1.0 - anisotropy), minAlpha);
    float c = cos(p.b.w);
    float s = sin(p.b.w);
    float sinH = sqrt(max(1.0 - p.a.w * p.a.w, 0.0));
    float sinV = sqrt(max(1.0 - p.a.y * p.a.y, 0.0));
    float sinL = sqrt(max(1.0 - p.a.z * p.a.z, 0.0));
    // The anisotropic lobe takes its cosines in fp32 (as SpecularDV passes them).
    float NoV = max(p.a.y, MIN_N_DOT_V);
    float NoL = saturate(p.a.z);
    return float4(V_SmithGGX_Separable(t.NoV, t.NoL, t.alpha), F_Schlick_Pow((real3)t.f0, (real)1.0, t.LoH).x,
                  D_GGX_Anisotropic(saturate(p.a.w), sinH * c, sinH * s, at, ab),
                  V_SmithGGXCorrelated_Anisotropic(at, ab, sinV, 0.0, sinL * c, sinL * s, NoV, NoL));
}
#elif defined(PROBE_DIFFUSE)
// Fd_Lambert, Fd_Burley, Fd_RenormalizedBurley, the mobile BRDF's V_Kelemen_UnityMobile.
float4 Evaluate(ProbeInput p)
{
    TermInputs t = DecodeTerms(p);
    return float4(Fd_Lambert(), Fd_Burley(t.NoV, t.NoL, t.LoH, t.perceptualRoughness),
                  Fd_RenormalizedBurley(t.NoV, t.NoL, t.LoH, t.perceptualRoughness),
                  V_Kelemen_UnityMobile(t.LoH, t.perceptualRoughness));
}
#elif defined(PROBE_LIGHTS)
// c = (distance^2, 1/range^2, cos inner, cos outer), d = (cos angle to the spot axis, kelvin, lumens, -):
// DistanceAttenuation, SpotAttenuation, SpotLightLumensToCandela, sum of ColorTemperatureToLinearRGB.
float4 Evaluate(ProbeInput p)
{
    float cosTheta = clamp(p.d.x, -1.0, 1.0);
    float3 L = float3(sqrt(max(1.0 - cosTheta * cosTheta, 0.0)), 0.0, -cosTheta);  // dot(-L, +Z) = cosTheta
    float3 temperature = ColorTemperatureToLinearRGB(p.d.y);
    return float4(DistanceAttenuation(p.c.x, p.c.y), SpotAttenuation(L, float3(0.0, 0.0, 1.0), SpotScaleOffset(p.c.z, p.c.w)),
                  SpotLightLumensToCandela(p.d.z, p.c.w), temperature.x + temperature.y + temperature.z);
}
#elif defined(PROBE_LIGHTS_MORE)
// The light functions PROBE_LIGHTS leaves out, and the mobile BRDF's exponent: c and d as PROBE_LIGHTS, d.w =
// perceptual roughness. PointLightLumensToCandela(d.z), DistanceAttenuation_UE4, DistanceAttenuation_InverseSquare,
// RoughnessToSpecularPower(d.w).
float4 Evaluate(ProbeInput p)
{
    return float4(PointLightLumensToCandela(p.d.z), DistanceAttenuation_UE4(p.c.x, p.c.y),
                  DistanceAttenuation_InverseSquare(p.c.x), RoughnessToSpecularPower((real)p.d.w));
}
#elif defined(PROBE_FOG)
// With one of FOG_LINEAR, FOG_EXP, FOG_EXP2 defined. c = (view depth, density, start, end), d = (color, fog color,
// camera offset along the forward axis, -): ComputeFogFactor, MixFog(color, fog color, factor), and
// ComputeFogDepth of the point at that depth in front of a camera looking along a tilted axis, seen from a camera
// moved back along it by d.z (so the depth read back is c.x + d.z), and 0.
float4 Evaluate(ProbeInput p)
{
    float factor = ComputeFogFactor(p.c.x, float4(p.c.y, p.c.z, p.c.w, 0.0));
    const float3 forward = float3(0.48, -0.6, -0.64);  // unit length
    const float3 camera = float3(1.0, 2.0, 3.0);
    float3 positionWS = camera + forward * p.c.x + float3(0.8, 0.0, 0.6) * 0.25;  // plus a step across the axis
    float depth = ComputeFogDepth(positionWS, camera - forward * p.d.z, forward);
    return float4(factor, MixFog(p.d.xxx, p.d.yyy, factor).x, depth, 0.0);
}
#elif defined(PROBE_SH9)
// SampleSH9 at the normal a.xyz with coefficient k = (s_k, s_k / 2, -s_k) (b.xyzw, c.xyzw, d.x hold s_0..s_8),
// so that the three channels exercise positive, halved and negated (clamped at 0) sums.
float4 Evaluate(ProbeInput p)
{
    float s[9] = { p.b.x, p.b.y, p.b.z, p.b.w, p.c.x, p.c.y, p.c.z, p.c.w, p.d.x };
    float4 sh[9];
    for (int k = 0; k < 9; ++k)
        sh[k] = float4(s[k], 0.5 * s[k], -s[k], 0.0);
    return float4(SampleSH9(sh, p.a.xyz), 0.0);
}
#elif defined(PROBE_IBL)
// EnvBRDFApprox at f0, EnergyCompensation and SpecularDFG with dfg = c.xy, ACESFitted of (d.x, d.y, d.z) (green).
float4 Evaluate(ProbeInput p)
{
    TermInputs t = DecodeTerms(p);
    real2 dfg = (real2)p.c.xy;
    return float4(EnvBRDFApprox((real3)t.f0, t.perceptualRoughness, t.NoV).x, EnergyCompensation(dfg, (real3)t.f0).x,
                  SpecularDFG(dfg, (real3)t.f0).x, ACESFitted(p.d.xyz).y);
}
#elif defined(PROBE_LIT)
// The full lit shading of one light plus image-based lighting, through the Forward pass's own functions
// (PrepareShading, AccumulateLight, IndirectLighting) and its keywords.
// a = (perceptual roughness, metallic, anisotropy, intensity), b = (normal, dfg.x), c = (towards the eye, dfg.y),
// d = (towards the light, kind: 0 directional, 1 point, 2 spot with equal inner and outer angles).
float4 Evaluate(ProbeInput p)
{
    SurfaceData surface;
    surface.baseColor = (real3)float3(0.9, 0.6, 0.3);
    surface.metallic = (real)saturate(p.a.y);
    surface.perceptualRoughness = (real)p.a.x;
    surface.reflectance = (real)0.5;
    surface.anisotropy = (real)clamp(p.a.z, -1.0, 1.0);
    // As InitializeSurface does: safe normalization with the same fallbacks, Gram-Schmidt for the tangent.
    surface.normalWS = SafeNormalize(p.b.xyz, float3(0.0, 1.0, 0.0));
    float3 tangent = float3(1.0, 0.0, 0.0) - surface.normalWS * surface.normalWS.x;
    surface.tangentWS = SafeNormalize(tangent, abs(surface.normalWS.x) < 0.9 ? float3(1.0, 0.0, 0.0) : float3(0.0, 0.0, 1.0));
    surface.bitangentWS = cross(surface.normalWS, surface.tangentWS);
    surface.viewWS = SafeNormalize(p.c.xyz, surface.normalWS);
    real2 dfg = (real2)saturate(float2(p.b.w, p.c.w));
    ShadingData s = PrepareShading(surface, dfg);

    float intensity = p.a.w;
    Light light;
    if (p.d.w < 0.5)
        light = DirectionalLight(p.d.xyz, (float3)intensity);
    else
        light = PunctualLight(p.d.xyz, (float3)intensity, 1.0 / 100.0, float4(0.0, -1.0, 0.0, p.d.w > 1.5 ? 1.0 : 0.0),
                              SpotScaleOffset(0.9, 0.9));
    float3 radiance = AccumulateLight(s, light);  // fp32, as LitFragment sums it
    radiance += (float3)IndirectLighting(s, (float3)(intensity * 0.01), (float3)(intensity * 0.01));
    return float4(radiance.r, radiance.g, radiance.b, ACESFitted(radiance).g);
}
#elif defined(PROBE_DIRECT)
// DirectBRDF (BRDF * NoL per unit illuminance) and AccumulateLight in the frame N = +Z, V = (sin, 0, NoV), for
// the energy of the direct specular lobe (tests/stress/accuracy_test.cpp integrates it over L).
// a = (perceptual roughness, NoV, dfg.x, dfg.y), b = (L, -), c = (V, -) with V.z = NoV (unit within fp32 rounding).
// x: white metal (f0 = 1, no diffuse), y: grey dielectric (base 0.5, reflectance 0.5),
// z: AccumulateLight of the white metal under a directional light of illuminance 1 along L, w: 0.
ShadingData ProbeShading(ProbeInput p, real3 baseColor, real metallic)
{
    SurfaceData surface;
    surface.baseColor = baseColor;
    surface.metallic = metallic;
    surface.perceptualRoughness = (real)p.a.x;
    surface.reflectance = (real)0.5;
    surface.anisotropy = (real)0.0;
    surface.normalWS = float3(0.0, 0.0, 1.0);
    surface.tangentWS = float3(1.0, 0.0, 0.0);
    surface.bitangentWS = float3(0.0, 1.0, 0.0);
    surface.viewWS = p.c.xyz;
    return PrepareShading(surface, (real2)p.a.zw);
}
float4 Evaluate(ProbeInput p)
{
    ShadingData metal = ProbeShading(p, (real3)1.0, (real)1.0);
    ShadingData dielectric = ProbeShading(p, (real3)0.5, (real)0.0);
    float3 L = p.b.xyz;
    return float4(DirectBRDF(metal, L).x, DirectBRDF(dielectric, L).x,
                  AccumulateLight(metal, DirectionalLight(L, (float3)1.0)).x, 0.0);
}
#elif defined(PROBE_TEXTBOOK)
// The unguarded textbook Cook-Torrance kernel (no roughness clamp, no NoV floor, no saturation):
// D * G * F / (4 NoV NoL) with Schlick-GGX G (k = alpha / 2). It must fail the stress grid.
float4 Evaluate(ProbeInput p)
{
    real alpha = (real)(p.a.x * p.a.x);
    real NoV = (real)p.a.y;
    real NoL = (real)p.a.z;
    real NoH = (real)p.a.w;
    real alpha2 = alpha * alpha;
    real d = NoH * NoH * (alpha2 - (real)1.0) + (real)1.0;
    real D = alpha2 / ((real)PI * d * d);
    real k = alpha * (real)0.5;
    real G = NoV / (NoV * ((real)1.0 - k) + k) * NoL / (NoL * ((real)1.0 - k) + k);
    real F = (real)p.b.y + ((real)1.0 - (real)p.b.y) * (real)pow((real)1.0 - (real)p.b.x, (real)5.0);
    return float4(D * G * F / ((real)4.0 * NoV * NoL), D, G, F);
}
#elif defined(PROBE_TABLE)
// a = (perceptual roughness, NoV, -, -): the DFG table bound at t21 (x, y) and EnvBRDFApprox's (scale, bias).
float4 Evaluate(ProbeInput p)
{
    real NoV = (real)max(p.a.y, MIN_N_DOT_V);
    real2 dfg = SampleDFG(gProbeTable, gProbeSampler, NoV, ClampedPerceptualRoughness((real)p.a.x));
    real3 approxBias = EnvBRDFApprox((real3)0.0, ClampedPerceptualRoughness((real)p.a.x), NoV);
    real3 approxOne = EnvBRDFApprox((real3)1.0, ClampedPerceptualRoughness((real)p.a.x), NoV);
    return float4(dfg.x, dfg.y, approxOne.x - approxBias.x, approxBias.x);
}
#elif defined(PROBE_TERM)
// One term per TERM_* define, in x, for the cost-versus-error study (bench/shading_study.cpp): the compiled
// probe's weighted instruction count minus the TERM_NONE probe's is the term's cost.
// TERM_APPLY_VERTEX_LIGHTING is compiled for its cost only.
// a = (perceptual roughness, NoV, NoL, NoH), b = (LoH, f0, distance^2, 1/range^2),
// c = (light position relative to the triangle's first vertex), d = (barycentric u, v, triangle edge length, -).
float4 Evaluate(ProbeInput p)
{
    TermInputs t = DecodeTerms(p);
    float value = 0.0;
#if defined(TERM_D_GGX)
    value = D_GGX(t.NoH, t.alpha, t.oneMinusNoHSquared);
#elif defined(TERM_V_CORRELATED)
    value = V_SmithGGXCorrelated(t.NoV, t.NoL, t.alpha);
#elif defined(TERM_V_FAST)
    value = V_SmithGGXCorrelated_Fast(t.NoV, t.NoL, t.alpha);
#elif defined(TERM_V_SEPARABLE)
    value = V_SmithGGX_Separable(t.NoV, t.NoL, t.alpha);
#elif defined(TERM_F_SCHLICK)
    value = F_Schlick(t.f0, (real)1.0, t.LoH);
#elif defined(TERM_F_SCHLICK_POW)
    value = F_Schlick_Pow((real3)t.f0, (real)1.0, t.LoH).x;
#elif defined(TERM_FD_LAMBERT)
    value = Fd_Lambert();
#elif defined(TERM_FD_BURLEY)
    value = Fd_Burley(t.NoV, t.NoL, t.LoH, t.perceptualRoughness);
#elif defined(TERM_FD_RENORMALIZED_BURLEY)
    value = Fd_RenormalizedBurley(t.NoV, t.NoL, t.LoH, t.perceptualRoughness);
#elif defined(TERM_ENV_TABLE)
    value = SpecularDFG(SampleDFG(gProbeTable, gProbeSampler, t.NoV, t.perceptualRoughness), (real3)t.f0).x;
#elif defined(TERM_ENV_APPROX)
    value = EnvBRDFApprox((real3)t.f0, t.perceptualRoughness, t.NoV).x;
#elif defined(TERM_ENERGY_COMPENSATION)
    value = EnergyCompensation(SampleDFG(gProbeTable, gProbeSampler, t.NoV, t.perceptualRoughness), (real3)t.f0).x;
#elif defined(TERM_FALLOFF_WINDOWED)
    value = DistanceAttenuation(p.b.z, p.b.w);
#elif defined(TERM_FALLOFF_UE4)
    value = DistanceAttenuation_UE4(p.b.z, p.b.w);
#elif defined(TERM_FALLOFF_INVERSE_SQUARE)
    value = DistanceAttenuation_InverseSquare(p.b.z);
#elif defined(TERM_LAMBERT_PER_PIXEL) || defined(TERM_LAMBERT_PER_VERTEX)
    // Irradiance / pi from a point light of 1 cd on a triangle (0,0,0), (e,0,0), (0,0,e) with normal +Y, at
    // barycentric (u, v): per pixel, or interpolated from the three vertices as _ADDITIONAL_LIGHTS_VERTEX does.
    float e = p.d.z;
    float3 vertices[3] = { float3(0.0, 0.0, 0.0), float3(e, 0.0, 0.0), float3(0.0, 0.0, e) };
    float3 weights = float3(1.0 - p.d.x - p.d.y, p.d.x, p.d.y);
#if defined(TERM_LAMBERT_PER_PIXEL)
    float3 position = vertices[0] * weights.x + vertices[1] * weights.y + vertices[2] * weights.z;
    Light light = PunctualLight(p.c.xyz - position, (float3)1.0, 1.0 / 400.0, (float4)0.0, (float2)0.0);
    value = light.radiance.x * saturate(light.L.y) * INV_PI;
#else
    for (int k = 0; k < 3; ++k)
    {
        Light light = PunctualLight(p.c.xyz - vertices[k], (float3)1.0, 1.0 / 400.0, (float4)0.0, (float2)0.0);
        value += weights[k] * light.radiance.x * saturate(light.L.y) * INV_PI;
    }
#endif
#elif defined(TERM_ADDITIONAL_LIGHTS)
    // a.xy = the point's (x, z) on the ground plane y = 0, b.xy = its pixel (the Forward+ tile lookup).
    // A grey dielectric (base color 0.8, roughness 0.5) seen from above; the frame's lights in the bound buffers.
    SurfaceData surface;
    surface.baseColor = (real3)0.8;
    surface.metallic = (real)0.0;
    surface.perceptualRoughness = (real)0.5;
    surface.reflectance = (real)0.5;
    surface.anisotropy = (real)0.0;
    surface.normalWS = float3(0.0, 1.0, 0.0);
    surface.tangentWS = float3(1.0, 0.0, 0.0);
    surface.bitangentWS = float3(0.0, 0.0, 1.0);
    surface.viewWS = normalize(float3(0.0, 1.0, 0.3));
    ShadingData s = PrepareShading(surface, (real2)float2(0.5, 0.9));
    value = AdditionalLightsRadiance(s, float3(p.a.x, 0.0, p.a.y), p.b.xy).x;
#elif defined(TERM_APPLY_VERTEX_LIGHTING)
    // What the fragment stage of _ADDITIONAL_LIGHTS_VERTEX does: scale the interpolated irradiance (c.xyz).
    value = (p.c.xyz * p.d.xyz).x;
#endif  // TERM_NONE: value stays 0
    // y always reads the record, so that every probe (TERM_NONE included) pays the same fetch overhead and
    // subtracting TERM_NONE's cost leaves the term's own cost.
    return float4(value, p.a.x, 0.0, 0.0);
}
#else
// PROBE_BASELINE: reads the record and writes it back; the cost study subtracts its instruction count.
float4 Evaluate(ProbeInput p)
{
    return p.a + p.b + p.c + p.d;
}
#endif

float4 ProbeFragment(float4 positionCS : SV_Position) : SV_Target
{
    uint index = (uint)positionCS.y * PROBE_WIDTH + (uint)positionCS.x;
    return Evaluate(gProbeInputs[index]);
}
