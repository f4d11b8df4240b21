// K_cache-invariant summation of the gather (a requirement: "changing K_cache changes results by
// <= 1e-5 relative"). Float addition is not associative, so the sums may depend on how the VALs
// are split into passes only if the grouping does. Both gather variants therefore add the VALs
// in one fixed grouping, whatever the pass size:
//   block b = VALs [16 b, 16 b + 16) of the VAL list, summed from zero in list order;
//   running sum = ((0 + block 0) + block 1) + ...,  carried from pass to pass in the targets
//   (each pass reads its own texel's running sum and writes it back: no additive blending).
// K_cache and the compute variant's VALs per dispatch are multiples of 16, so a pass never splits
// a block, and every sum is the same float number for every K_cache (measured: bitwise equal).
// Error: at most (15 + n/16) roundings for n VALs (blending chunks of K: K - 1 + n/K).
// `precise`: no reassociation or fused multiply-add contraction of the accumulations, so the
// fragment and compute variants round alike.
#ifndef GATHER_SUM_BLOCK_GLSL
#define GATHER_SUM_BLOCK_GLSL
const int kSumBlock = 16; // VALs per block; K_cache and VALs per dispatch are multiples of it

// Running sums of one sparse point: the five gather targets (see LightSkinIllumination.cpp).
struct GatherSums {
    vec4 diffuse;  // L'_d.rgb, sum r^2 w_d
    vec4 offsetD;  // sum (l - x) w_d, W_d
    vec4 glossy;   // L'_s.rgb, sum r^2 w_s
    vec4 offsetS;  // sum (l - x) w_s, W_s
    vec4 moments;  // sum (l - x)^2 w_d per axis, sum |l - x|^2 w_s
};

GatherSums gather_zeroSums() {
    GatherSums z;
    z.diffuse = vec4(0.0);
    z.offsetD = vec4(0.0);
    z.glossy = vec4(0.0);
    z.offsetS = vec4(0.0);
    z.moments = vec4(0.0);
    return z;
}

// One VAL's terms added to a block sum (eq. 7 without the eps_l terms, see gather_val_sums.comp).
GatherSums gather_addSample(GatherSums sums, GatherSample s) {
    precise GatherSums r = sums;
    r.diffuse += vec4(s.irradiance, s.r2 * s.weightD);
    r.offsetD += vec4(s.offset * s.weightD, s.weightD);
#ifdef GLOSSY
    r.glossy += vec4(s.glossy, s.r2 * s.weightS);
    r.offsetS += vec4(s.offset * s.weightS, s.weightS);
#endif
#ifdef OCCLUSION
    r.moments.xyz += s.offset * s.offset * s.weightD;
#ifdef GLOSSY
    r.moments.w += dot(s.offset, s.offset) * s.weightS;
#endif
#endif
    return r;
}

// running + block, component-wise.
GatherSums gather_addBlock(GatherSums running, GatherSums block) {
    precise GatherSums r;
    r.diffuse = running.diffuse + block.diffuse;
    r.offsetD = running.offsetD + block.offsetD;
    r.glossy = running.glossy + block.glossy;
    r.offsetS = running.offsetS + block.offsetS;
    r.moments = running.moments + block.moments;
    return r;
}
#endif
