#version 450 core
// llvmpipe's fragment-shader arithmetic peak (bench/PeakFlopsBenchmark.cpp): CHAINS independent vec4
// FMA chains per fragment, uIterations steps each (uIterations < 65,000: llvmpipe ends longer loops).
// Per fragment: uIterations * CHAINS * 4 FMAs = 8 * uIterations * CHAINS flops. The coefficients
// come from uniforms (nothing folds at compile time); a < 1 keeps every chain finite and normal.
#ifndef CHAINS
#define CHAINS 8
#endif
uniform int uIterations;
uniform float uA; // multiplier, 0 < uA < 1
uniform float uB; // addend
layout(location = 0) out vec4 outSum;

void main() {
    vec4 acc[CHAINS];
    for (int c = 0; c < CHAINS; ++c) acc[c] = vec4(gl_FragCoord.xy * 1.0e-3, float(c), 1.0);
    for (int i = 0; i < uIterations; ++i)
        for (int c = 0; c < CHAINS; ++c) acc[c] = fma(acc[c], vec4(uA), vec4(uB));
    vec4 sum = vec4(0.0);
    for (int c = 0; c < CHAINS; ++c) sum += acc[c];
    outSum = sum;
}
