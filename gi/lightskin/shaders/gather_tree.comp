#version 450 core
// Gather with a cut through the VAL tree (ValTree.h, val_tree_math.glsl): one thread per sparse
// point walks the tree depth first, the nearer child first; a leaf adds its VAL exactly (eq. 3-5, 7), an
// inner cluster is taken as one light when its error bound U <= uThreshold x the running estimate (per
// channel, diffuse and, with GLOSSY, glossy), else the walk descends. The estimate is lightcuts': the
// sums taken so far (the targets) plus the one-light approximations of the clusters on the stack.
// Each dispatch runs at most uSteps iterations per thread (llvmpipe ends loops after ~65k); the walk's
// state (stack, pending estimate) persists in buffers between dispatches, the sums in the targets as
// in gather_sparse.comp. The same walk as the reference (gi/reference/src/ValTreeReference.cpp).
// Variants: GLOSSY, OCCLUSION (second moments, with each cluster's spread added).
#include "lightskin_math.glsl"
#include "val_tree_math.glsl"
#include "virtual_area_light.glsl"
#include "gather_sparse_points.glsl"
#include "gather_sum_block.glsl"

layout(local_size_x = 64) in;

// lightskin::gi::ValCluster (ValTree.h), std430, 112 bytes
struct ValCluster {
    vec4 positionR2Mean; // flux-weighted mean position, r2Mean
    vec4 axisScale;      // cone axis, normalScale
    vec4 fluxR2Sum;      // total flux, r2Sum
    vec4 boxMinCone;     // box min, cone half angle
    vec4 boxMaxR2Min;    // box max, r2Min
    vec4 varianceCount;  // per-axis variance, count
    uvec4 children;      // child0 (VAL index of a leaf), child1 (0xFFFFFFFF for a leaf)
};
const uint kLeaf = 0xFFFFFFFFu;
const int kStackSize = 65; // kValTreeMaxDepth + 1

layout(std430, binding = 0) readonly buffer Vals { VirtualAreaLight vals[]; };
layout(std430, binding = 1) readonly buffer Nodes { ValCluster nodes[]; };
// per point two vec4: pending estimate (diffuse rgb, stack height as float: exact below 2^24) and (glossy rgb)
layout(std430, binding = 2) buffer Walk { vec4 walk[]; };
// per point kStackSize entries: the node, its approximation (diffuse rgb) and (glossy rgb)
layout(std430, binding = 3) buffer StackD { vec4 stackD[]; };
layout(std430, binding = 4) buffer StackS { vec4 stackS[]; };
layout(std430, binding = 5) buffer StackNode { uint stackNode[]; };
// [0] points still walking after this dispatch, [1] nodes visited, [2] cut size (lights taken)
layout(std430, binding = 6) buffer Counters { uint counters[]; };

layout(binding = 0, rgba32f) uniform image2D uOutDiffuse;
layout(binding = 1, rgba32f) uniform image2D uOutOffsetD;
layout(binding = 2, rgba32f) uniform image2D uOutGlossy;
layout(binding = 3, rgba32f) uniform image2D uOutOffsetS;
layout(binding = 4, rgba32f) uniform image2D uOutMoments;
uniform uint uSteps;
uniform int uFirstDispatch;
uniform float uThreshold;
uniform vec3 uEye;
uniform float uC;

GatherSample nodeSample(uint node, vec3 x, vec3 n, vec3 toEye, float k, float ck) {
    const ValCluster c = nodes[node];
    if (c.children.y == kLeaf) {
        const VirtualAreaLight l = vals[c.children.x];
        return ls_gatherSample(x, n, l.positionArea.xyz, l.normal.xyz, l.positionArea.w, l.flux.rgb, toEye, k, ck, 0.0,
                               LS_NEAR_FIELD != 0);
    }
    return vt_clusterSample(x, n, c.positionR2Mean.xyz, c.axisScale.xyz, c.axisScale.w, c.positionR2Mean.w,
                            c.fluxR2Sum.w, c.fluxR2Sum.rgb, toEye, k, ck);
}

bool within(vec3 bound, vec3 estimate) { return all(lessThanEqual(bound, uThreshold * estimate)); }

void main() {
    const int index = int(gl_GlobalInvocationID.x);
    if (index >= uPointCount) return;
    const uint point = uint(index);
    const ivec2 texel = gather_pointTexel(index);
    const vec4 positionK = texelFetch(uPointPosition, texel, 0);
    const vec3 x = positionK.xyz;
    const vec3 n = texelFetch(uPointNormal, texel, 0).xyz;
    const float k = positionK.w;
    const float ck = uC * (k + 1.0);
    const vec3 toEye = ls_toEye(x, uEye);
    const uint base = point * uint(kStackSize);

    uint top;
    vec3 pendingD, pendingS;
    if (uFirstDispatch != 0) {
        const GatherSample root = nodeSample(0u, x, n, toEye, k, ck);
        stackD[base] = vec4(root.irradiance, 0.0);
        stackS[base] = vec4(root.glossy, 0.0);
        stackNode[base] = 0u;
        top = 1u;
        pendingD = root.irradiance;
        pendingS = root.glossy;
    } else {
        const vec4 w = walk[2u * point];
        top = uint(w.w);
        if (top == 0u) return;
        pendingD = w.rgb;
        pendingS = walk[2u * point + 1u].rgb;
    }
    GatherSums running;
    running.diffuse = imageLoad(uOutDiffuse, texel);
    running.offsetD = imageLoad(uOutOffsetD, texel);
    running.glossy = imageLoad(uOutGlossy, texel);
    running.offsetS = imageLoad(uOutOffsetS, texel);
    running.moments = imageLoad(uOutMoments, texel);

    uint visited = 0u, taken = 0u;
    for (uint step = 0u; step < uSteps && top > 0u; ++step) {
        --top;
        const vec4 entryD = stackD[base + top];
        const vec3 approxS = stackS[base + top].rgb;
        const uint node = stackNode[base + top];
        // float: the pending sum drifts by rounding; it only steers the choice, never the result
        pendingD = max(pendingD - entryD.rgb, vec3(0.0));
        pendingS = max(pendingS - approxS, vec3(0.0));
        ++visited;
        const ValCluster c = nodes[node];
        bool take = c.children.y == kLeaf;
        vec3 variance = vec3(0.0);
        if (!take) {
            const vec2 g = vt_clusterBound(x, n, c.boxMinCone.xyz, c.boxMaxR2Min.xyz, c.axisScale.xyz, c.boxMinCone.w,
                                           c.boxMaxR2Min.w, c.fluxR2Sum.w, toEye, k, LS_NEAR_FIELD != 0);
            const vec3 boundD = c.fluxR2Sum.rgb * (g.x / kPi);
            take = within(boundD, running.diffuse.rgb + pendingD + entryD.rgb);
#ifdef GLOSSY
            const vec3 boundS = c.fluxR2Sum.rgb * (ck * g.y / kPi);
            take = take && within(boundS, running.glossy.rgb + pendingS + approxS);
#endif
            variance = c.varianceCount.xyz;
        }
        if (take) {
            const GatherSample s = nodeSample(node, x, n, toEye, k, ck);
            GatherSums one = gather_addSample(gather_zeroSums(), s);
#ifdef OCCLUSION
            one.moments.xyz += variance * s.weightD; // the cluster's spread (parallel axis theorem)
#ifdef GLOSSY
            one.moments.w += (variance.x + variance.y + variance.z) * s.weightS;
#endif
#endif
            running = gather_addBlock(running, one);
            ++taken;
            continue;
        }
        // children: the nearer one on top (judged first, the farther still counts in the estimate)
        const uint a = c.children.x, b = c.children.y;
        const vec3 qa = max(max(nodes[a].boxMinCone.xyz - x, x - nodes[a].boxMaxR2Min.xyz), vec3(0.0));
        const vec3 qb = max(max(nodes[b].boxMinCone.xyz - x, x - nodes[b].boxMaxR2Min.xyz), vec3(0.0));
        const bool aNearer = dot(qa, qa) <= dot(qb, qb);
        const uint far = aNearer ? b : a, near = aNearer ? a : b;
        const GatherSample sf = nodeSample(far, x, n, toEye, k, ck);
        const GatherSample sn = nodeSample(near, x, n, toEye, k, ck);
        stackD[base + top] = vec4(sf.irradiance, 0.0);
        stackS[base + top] = vec4(sf.glossy, 0.0);
        stackNode[base + top] = far;
        stackD[base + top + 1u] = vec4(sn.irradiance, 0.0);
        stackS[base + top + 1u] = vec4(sn.glossy, 0.0);
        stackNode[base + top + 1u] = near;
        top += 2u;
        pendingD += sf.irradiance + sn.irradiance;
        pendingS += sf.glossy + sn.glossy;
    }
    walk[2u * point] = vec4(pendingD, float(top));
    walk[2u * point + 1u] = vec4(pendingS, 0.0);
    imageStore(uOutDiffuse, texel, running.diffuse);
    imageStore(uOutOffsetD, texel, running.offsetD);
    imageStore(uOutGlossy, texel, running.glossy);
    imageStore(uOutOffsetS, texel, running.offsetS);
    imageStore(uOutMoments, texel, running.moments);
    if (top > 0u) atomicAdd(counters[0], 1u);
    atomicAdd(counters[1], visited);
    atomicAdd(counters[2], taken);
}
