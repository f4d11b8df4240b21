#version 450 core
// The depth image's VAL quadtree built on the GPU (lightskin::gi::GpuValQuadtree, ValTree.h):
// the same levels as the CPU builder buildValQuadtreeInto (neighbours paired alternately along u and v,
// a cell with one non-empty child IS that child), so the same tree, with the statistics combined in
// float instead of double. One variant per pass (prepended #define):
//   PASS_LEAVES: one invocation per VAL: a valid VAL (area > 0) becomes leaf node uLeafBase + i and
//                claims its pixel's cell; a key outside the image or a pixel claimed twice is counted
//                (info.errors, info.firstBad) and the CPU side throws.
//   PASS_LEVEL:  one invocation per cell of the next level: pairs the cells of the current level.
//   PASS_ROOT:   one invocation: copies the root to node 0 (where the walk starts) and reports it.
// Node numbering without a prefix sum and independent of thread timing: an inner node is stored at
// 1 + (VAL index of the leftmost leaf of its second child). Each leaf is that leftmost leaf for at
// most one inner node (walking up from the leaf while it is a first child, the first parent reached
// from a second child is the only one), so slots never collide; node 0 is left for the root's copy.
// A cell holds (node index, VAL index of its leftmost leaf); kEmpty = no VAL below.
#include "virtual_area_light.glsl"

layout(local_size_x = 64) in;

// lightskin::gi::ValCluster (ValTree.h), std430, 112 bytes; the same rows as gather_tree.comp
struct ValCluster {
    vec4 positionR2Mean;
    vec4 axisScale;
    vec4 fluxR2Sum;
    vec4 boxMinCone;
    vec4 boxMaxR2Min;
    vec4 varianceCount;
    uvec4 children;
};
const uint kLeaf = 0xFFFFFFFFu;
const uint kEmpty = 0xFFFFFFFFu;
const float kPi = 3.14159265358979;

layout(std430, binding = 1) buffer Nodes { ValCluster nodes[]; };
// [0] root node index (kEmpty: no valid VAL), [1] VALs in the tree, [2] key errors, [3] first bad VAL
layout(std430, binding = 2) buffer Info { uint info[]; };

#ifdef PASS_LEAVES
layout(std430, binding = 0) readonly buffer Vals { VirtualAreaLight vals[]; };
layout(std430, binding = 3) readonly buffer Keys { uint keys[]; };
layout(std430, binding = 4) buffer Cells { uvec2 cells[]; }; // the image, cleared to kEmpty
uniform uint uCount;    // VALs
uniform uint uPixels;   // image width * height
uniform uint uLeafBase; // node index of VAL 0's leaf
#else
layout(std430, binding = 4) readonly buffer InCells { uvec2 inCells[]; };
layout(std430, binding = 5) writeonly buffer OutCells { uvec2 outCells[]; };
#endif
#ifdef PASS_LEVEL
uniform uvec2 uInSize;  // current level, cells
uniform uvec2 uOutSize; // next level, cells
uniform bool uPairU;    // pair along u (else along v)
#endif

// --- Outward-rounded float cone arithmetic ----------------------------------------------------------
// The float cone angle must stay >= the exact angle between the stored (float) axis and every member's
// normal, for every node (the error bound of val_tree_math.glsl relies on it). GLSL has no double and
// no specified precision for asin/acos (GLSL 4.50, 4.7.1), so the angle is bounded with +, -, *, / and
// sqrt only, whose errors are specified: a/b <= 2.5 ULP, inversesqrt <= 2 ULP, sqrt as 1/inversesqrt
// <= 4.5 ULP, the rest correctly rounded; i.e. <= 5 ULP = 5 * 2^-23 ~ 6e-7 relative per operation.
//   Directions: for float vectors u, v near unit length, |u^ - v^| <= |u - v| + ||u| - 1| + ||v| - 1|.
//   Angle: theta = 2 asin(c / 2) for the chord c = |u^ - v^|, and theta <= 4 tan(theta / 4)
//   = 2 c / (1 + sqrt(1 - c^2 / 4)), increasing in c: an upper bound on c gives one on theta (at most
//   4 / pi = 1.27x theta at theta = pi, 1.055x at pi / 2, 1.001x at 0.1 rad).
//   Rounding: length() and the tangent formula are chains of <= 8 operations: <= 8 x 6e-7 = 4.8e-6
//   relative < 2^-17 (7.6e-6); so |u - v| is scaled by (1 + 2^-17), each |len - 1| (len in [0.5, 2],
//   the subtraction exact by Sterbenz) gets 2^-17 absolute (2 x 2^-17 relative of len), and the
//   radicand, whose absolute error is < 2^-21, is lowered by 2^-20 before its sqrt; the result and
//   the cone sum (angle + child cone: one rounded add, then max) are scaled by (1 + 2^-17).
const float kRelative = 1.0 + 7.62939453125e-06; // 1 + 2^-17
const float kAbsolute = 7.62939453125e-06;       // 2^-17
float vt_angleUpper(vec3 u, vec3 v) {
    const float c = length(u - v) * kRelative + abs(length(u) - 1.0) + abs(length(v) - 1.0) + 2.0 * kAbsolute;
    if (!(c < 2.0)) return kPi; // also NaN; >= the true angle since every angle is <= pi
    const float radicand = max(1.0 - 0.25 * c * c - 9.5367431640625e-07, 0.0); // 2^-20
    return min(2.0 * c / (1.0 + sqrt(radicand)) * kRelative, kPi);
}

// area / pi rounded down: two correctly rounded operations (the constant and the product, 2^-24 each)
// plus the scale 1 - 2^-21 (itself rounded by 2^-24) stay below the true value.
float vt_r2Down(float area) { return area * 0.318309886 * (1.0 - 4.76837158203125e-07); }

ValCluster vt_leaf(VirtualAreaLight l, uint index) {
    ValCluster c;
    const float r2 = l.positionArea.w / kPi;
    c.positionR2Mean = vec4(l.positionArea.xyz, max(r2, vt_r2Down(l.positionArea.w)));
    const vec3 n = l.normal.xyz;
    const float len = length(n);
    // a zero normal emits nothing (cos(theta_j) = 0); any axis with scale 0 says the same
    const bool hasNormal = len > 0.0 && !isinf(len);
    const vec3 axis = hasNormal ? n / len : vec3(0.0, 0.0, 1.0);
    // the float axis differs from n's direction by rounding: certified like an inner node's
    c.axisScale = vec4(axis, hasNormal ? 1.0 : 0.0);
    c.fluxR2Sum = vec4(l.flux.rgb, c.positionR2Mean.w);
    c.boxMinCone = vec4(l.positionArea.xyz, hasNormal ? vt_angleUpper(axis, n / len) : kPi);
    c.boxMaxR2Min = vec4(l.positionArea.xyz, vt_r2Down(l.positionArea.w));
    c.varianceCount = vec4(0.0, 0.0, 0.0, 1.0);
    c.children = uvec4(index, kLeaf, 0u, 0u);
    return c;
}

// ValTree.cpp's combine(), in float, with the cone rounded outward (above) and the representative
// position clamped into the box (rounding must not move it out: the bound assumes it inside).
ValCluster vt_combine(ValCluster a, ValCluster b) {
    ValCluster c;
    const vec3 fluxA = a.fluxR2Sum.rgb, fluxB = b.fluxR2Sum.rgb;
    const float phiA = fluxA.r + fluxA.g + fluxA.b, phiB = fluxB.r + fluxB.g + fluxB.b;
    // flux weights; black clusters (no flux, so no light either) fall back to counts for the geometry
    const bool byFlux = phiA + phiB > 0.0;
    const float wa = byFlux ? phiA : a.varianceCount.w, wb = byFlux ? phiB : b.varianceCount.w;
    const float w = wa + wb;
    const vec3 boxMin = min(a.boxMinCone.xyz, b.boxMinCone.xyz), boxMax = max(a.boxMaxR2Min.xyz, b.boxMaxR2Min.xyz);
    const vec3 position = clamp((wa * a.positionR2Mean.xyz + wb * b.positionR2Mean.xyz) / w, boxMin, boxMax);
    const vec3 da = a.positionR2Mean.xyz - position, db = b.positionR2Mean.xyz - position;
    const vec3 variance = (wa * (a.varianceCount.xyz + da * da) + wb * (b.varianceCount.xyz + db * db)) / w;
    const vec3 normalSum = wa * a.axisScale.w * a.axisScale.xyz + wb * b.axisScale.w * b.axisScale.xyz;
    const float len = length(normalSum);
    float cone = kPi;
    vec3 axis = vec3(0.0, 0.0, 1.0);
    if (len > 0.0 && !isinf(len)) {
        axis = normalSum / len;
        const float coneA = vt_angleUpper(axis, a.axisScale.xyz) + a.boxMinCone.w;
        const float coneB = vt_angleUpper(axis, b.axisScale.xyz) + b.boxMinCone.w;
        cone = min(max(coneA, coneB) * kRelative, kPi);
    }
    c.axisScale = vec4(axis, len > 0.0 ? min(len / w, 1.0) : 0.0);
    const float r2Sum = a.fluxR2Sum.w + b.fluxR2Sum.w;
    const float r2Min = min(a.boxMaxR2Min.w, b.boxMaxR2Min.w);
    float r2Mean = r2Sum > 0.0 ? (a.positionR2Mean.w * a.fluxR2Sum.w + b.positionR2Mean.w * b.fluxR2Sum.w) / r2Sum : 0.0;
    r2Mean = max(r2Mean, r2Min); // a mean of equal values may round below them; the bound needs >=
    c.positionR2Mean = vec4(position, r2Mean);
    c.fluxR2Sum = vec4(fluxA + fluxB, r2Sum);
    c.boxMinCone = vec4(boxMin, cone);
    c.boxMaxR2Min = vec4(boxMax, r2Min);
    c.varianceCount = vec4(variance, a.varianceCount.w + b.varianceCount.w);
    return c;
}

void main() {
#ifdef PASS_LEAVES
    const uint i = gl_GlobalInvocationID.x;
    if (i >= uCount) return;
    const VirtualAreaLight l = vals[i];
    if (!(l.positionArea.w > 0.0)) return; // invalid (also NaN): no leaf, as ValTree.cpp
    const uint key = keys[i];
    bool bad = key >= uPixels;
    if (!bad) {
        nodes[uLeafBase + i] = vt_leaf(l, i);
        bad = atomicCompSwap(cells[key].x, kEmpty, uLeafBase + i) != kEmpty;
        if (!bad) cells[key].y = i;
    }
    if (bad) {
        atomicAdd(info[2], 1u);
        atomicMin(info[3], i);
    }
#endif
#ifdef PASS_LEVEL
    const uint cell = gl_GlobalInvocationID.x;
    if (cell >= uOutSize.x * uOutSize.y) return;
    const uint x = cell % uOutSize.x, y = cell / uOutSize.x;
    const uint ia = uPairU ? y * uInSize.x + 2u * x : 2u * y * uInSize.x + x;
    const bool hasB = uPairU ? 2u * x + 1u < uInSize.x : 2u * y + 1u < uInSize.y;
    const uvec2 a = inCells[ia];
    const uvec2 b = hasB ? inCells[uPairU ? ia + 1u : ia + uInSize.x] : uvec2(kEmpty);
    if (a.x == kEmpty || b.x == kEmpty) {
        outCells[cell] = a.x == kEmpty ? b : a;
        return;
    }
    ValCluster c = vt_combine(nodes[a.x], nodes[b.x]);
    c.children = uvec4(a.x, b.x, 0u, 0u);
    const uint slot = 1u + b.y; // see the file comment
    nodes[slot] = c;
    outCells[cell] = uvec2(slot, a.y);
#endif
#ifdef PASS_ROOT
    if (gl_GlobalInvocationID.x != 0u) return;
    const uint root = inCells[0].x;
    info[0] = root;
    if (root == kEmpty) {
        info[1] = 0u;
        return;
    }
    const ValCluster c = nodes[root];
    nodes[0] = c;
    info[1] = uint(c.varianceCount.w);
#endif
}
