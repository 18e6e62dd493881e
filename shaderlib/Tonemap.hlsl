// kiln shaderlib: Tonemap.hlsl — ACES filmic tone mapping, the last step of the Forward pass.
#ifndef KILN_TONEMAP_INCLUDED
#define KILN_TONEMAP_INCLUDED

// Hill 2016 (BakingLab), the RRT+ODT fit of ACES 1.0 with sRGB-to-ACES input and output matrices.
// Always evaluated in fp32: the rational fit squares its input, which overflows fp16 above ~250.
float3 RRTAndODTFit(float3 v)
{
    float3 a = v * (v + 0.0245786) - 0.000090537;
    float3 b = v * (0.983729 * v + 0.4329510) + 0.238081;
    return a / b;  // b >= 0.238 for v >= 0: never zero
}

float3 ACESFitted(float3 color)
{
    // Negative or NaN radiance is clamped to 0; 1e5 bounds the squares far below fp32 overflow while the
    // curve has long saturated (the fit reaches 0.99 of its asymptote near 30).
    color = clamp(color, 0.0, 1e5);
    const float3x3 inputMatrix = float3x3(0.59719, 0.35458, 0.04823,
                                          0.07600, 0.90834, 0.01566,
                                          0.02840, 0.13383, 0.83777);
    const float3x3 outputMatrix = float3x3( 1.60475, -0.53108, -0.07367,
                                           -0.10208,  1.10813, -0.00605,
                                           -0.00327, -0.07276,  1.07602);
    color = mul(inputMatrix, color);
    color = RRTAndODTFit(color);
    color = mul(outputMatrix, color);
    return saturate(color);
}

#endif // KILN_TONEMAP_INCLUDED
// SPDX-License-Identifier: Apache-2.0
