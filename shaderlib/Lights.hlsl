// kiln shaderlib: Lights.hlsl — punctual lights in photometric units (seed 002; Karis 2013; Lagarde 2014).
// Directional lights carry illuminance (lux); point and spot lights carry luminous intensity (candela).
#ifndef KILN_LIGHTS_INCLUDED
#define KILN_LIGHTS_INCLUDED

#include "Common.hlsl"

// Lumen to candela. Point light: the full sphere, 4 pi sr (seed 002).
float PointLightLumensToCandela(float lumens) { return lumens / (4.0 * PI); }

// Spot light: the cone's solid angle 2 pi (1 - cos(outer)) (seed 002). The floor of 1e-6 sr keeps a
// degenerate zero-angle cone finite.
float SpotLightLumensToCandela(float lumens, float cosOuter)
{
    return lumens / max(2.0 * PI * (1.0 - cosOuter), 1e-6);
}

// Karis 2013, "Real Shading in Unreal Engine 4": the windowing factor saturate(1 - (d/r)^4)^2 that brings
// the inverse-square law to exactly zero at the light's range r.
float DistanceWindow(float distanceSquared, float inverseRangeSquared)
{
    float factor = distanceSquared * inverseRangeSquared;
    float smoothFactor = saturate(1.0 - factor * factor);
    return smoothFactor * smoothFactor;
}

// Inverse-square falloff with the window. 1e-4 m^2 floor: a light never closer than 1 cm (Filament), so
// distance 0 gives a large finite value instead of Inf. Karis's +1 in the denominator is not used: it
// makes a 1 m light 2x too dark and breaks the photometric units.
float DistanceAttenuation(float distanceSquared, float inverseRangeSquared)
{
    return DistanceWindow(distanceSquared, inverseRangeSquared) / max(distanceSquared, 1e-4);
}

// Seed 002's literal UE4 form, with +1 in the denominator, for comparison in the benchmark.
float DistanceAttenuation_UE4(float distanceSquared, float inverseRangeSquared)
{
    return DistanceWindow(distanceSquared, inverseRangeSquared) / (distanceSquared + 1.0);
}

// Pure inverse square (the physical law), floored at 1 cm like DistanceAttenuation.
float DistanceAttenuation_InverseSquare(float distanceSquared)
{
    return 1.0 / max(distanceSquared, 1e-4);
}

// Scale and offset for the smooth spot cone: saturate(cosTheta * scale + offset)^2 (seed 002).
// cosInner - cosOuter is floored at 1e-4 so equal inner and outer angles give a hard edge, not 0/0.
float2 SpotScaleOffset(float cosInner, float cosOuter)
{
    float scale = 1.0 / max(cosInner - cosOuter, 1e-4);
    return float2(scale, -cosOuter * scale);
}

// spotDirectionWS points from the light along its axis; L points from the surface to the light.
float SpotAttenuation(float3 L, float3 spotDirectionWS, float2 scaleOffset)
{
    float cosTheta = dot(-L, spotDirectionWS);
    float attenuation = saturate(cosTheta * scaleOffset.x + scaleOffset.y);
    return attenuation * attenuation;
}

// Correlated color temperature (Kelvin, 1000-40000) to linear RGB, HDRP's fit, max error 0.008 (seed 002).
float3 ColorTemperatureToLinearRGB(float temperature)
{
    float kelvin = clamp(temperature, 1000.0, 40000.0) / 1000.0;
    float kelvin2 = kelvin * kelvin;
    // Pivot 6.57: the fits for red and for green/blue switch form there (HDRP LightUtils.cs).
    float r = kelvin < 6.570 ? 1.0 : saturate((1.35651 + 0.216422 * kelvin + 0.000633715 * kelvin2) / (-3.24223 + 0.918711 * kelvin));
    float g = kelvin < 6.570
        ? saturate((-399.809 + 414.271 * kelvin + 111.543 * kelvin2) / (2779.24 + 164.143 * kelvin + 84.7356 * kelvin2))
        : saturate((1370.38 + 734.616 * kelvin + 0.689955 * kelvin2) / (-4625.69 + 1699.87 * kelvin));
    float b = kelvin > 6.570 ? 1.0 : saturate((348.963 - 523.53 * kelvin + 183.62 * kelvin2) / (2848.82 - 214.52 * kelvin + 78.8614 * kelvin2));
    return float3(r, g, b);
}

#endif // KILN_LIGHTS_INCLUDED
// SPDX-License-Identifier: Apache-2.0
