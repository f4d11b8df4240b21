// A cluster of VALs standing in for its members at one receiver, and a conservative bound on the
// error of doing so (lightcuts-style: Walter et al. 2005, section 4.1). Written once in the
// common subset of GLSL 4.50 and C++/GLM like lightskin_math.glsl (which must be included first):
// gather_tree.comp includes it with real = float, the double reference (gi/lightskin/src/ValTreeMath.h)
// with real = double.
//
// A cluster C (lightskin::gi::ValClusterT, ValTree.h) holds: total flux Phi (RGB, W), flux-weighted
// mean position p, unit axis a = normalize(sum phi_j n_j) with s = |sum phi_j n_j| / sum phi_j <= 1,
// r2Sum = sum r_j^2, r2Mean = sum r_j^4 / sum r_j^2, r2Min = min r_j^2, per-axis position variance
// (flux-weighted), bounding box [lo, hi] of the positions and the normal cone (a, coneAngle) that holds
// every n_j. (phi_j: the channel sum of the VAL's flux.)
//
// Approximation (vt_clusterSample): the members as co-located discs at p: sum_j phi_j cos(theta_j) =
// -(sum_j phi_j n_j) . u = Phi s cos(theta_a) exactly when all face the receiver, and r_j^2 ~ r2Mean in
// eq. 3's denominator. Eq. 7's statistics: W = r2Sum s g cos(theta_i) (sum of the members' w_j),
// sum r^2 w = r2Mean W, the second moments get the cluster's variance (parallel axis theorem) so S_o
// keeps the spread of the VALs (section 3.3, G9).
//
// Bound (vt_clusterBound): every member's E_j = phi_j cos(theta_j) cos(theta_i) / (pi (r_j^2 + d_j^2))
// with d_j >= dMin (distance from x to the box), r_j^2 >= r2Min, cos(theta_i) <= cosIMax over the box,
// cos(theta_j) <= cosJMax over the box and the cone; so 0 <= sum_j E_j <= U = Phi G / pi with
// G = cosJMax cosIMax / (r2Min + dMin^2). The approximation satisfies the same bounds (p lies in the
// box, a in the cone, r2Mean >= r2Min, s <= 1), so |approx - exact| <= U per channel. The glossy
// channel: the lobe cos^k(gamma) <= lobeMax = cos^k of the smallest angle between the mirrored eye
// direction and the cone of directions to the box (1 when x lies in the box's bounding sphere), gated by
// cos(theta_i) > 0: U_s = c_k Phi G_s / pi with G_s = cosJMax lobeMax [cosIMax > 0] / (r2Min + dMin^2).
//   cosIMax: 0 when the whole box lies on or below the receiver's tangent plane (exact: max over the
//   box corners of n.(l - x) <= 0), else min(1, that max / dMin, cos(max(angle(n, c - x) - beta, 0)))
//   with beta the half angle of the cone of directions from x to the box's bounding sphere (c, R);
//   cosJMax: cos(max(angle(a, x - c) - beta - coneAngle, 0)), 0 past 90 degrees; 1 when x lies in the
//   bounding sphere. Angles come from acos, whose float error near 1 is ~3.5e-4 rad: kTreeAngleSlack
//   (1e-3 rad) is subtracted from every angle so that the float bound stays an upper bound.
// Near-field VALs (guard G12 of lightskin_math.glsl): a member within kNearFieldRatio r_j of x is
// integrated as an area, which the bound above does not cover (beside its rim the area form factor is
// ~100x eq. 3's). Every member has r_j^2 <= r2Sum and d_j >= dMin, so dMin^2 >= kNearFieldRatio2 r2Sum
// proves that no member is in its near field; otherwise the bound is kTreeDescend (the cluster is
// never taken: its children are examined, down to the leaves, which are exact).
// The eq.-7 weights and positions are not bounded (they enter the image only through eq. 8-11's
// ratios); their error is measured (tests/gi/lightskin/ValTreeTest.cpp, docs/BENCHMARKS.md).

#ifndef LIGHTSKIN_VAL_TREE_MATH_GLSL
#define LIGHTSKIN_VAL_TREE_MATH_GLSL

const real kTreeAngleSlack = 1.0e-3; // rad, > float acos error near 1 (sqrt(2 * 6e-8) = 3.5e-4)
const real kHalfPi = 1.57079632679489661923;
const real kTreeDescend = 1.0e30; // a bound no threshold accepts (G12); finite, so flux * it stays finite

// rvec2(G, G_s) of the bound above: U_d = Phi G / pi, U_s = c_k Phi G_s / pi. toEye, k, nearField: as
// ls_gatherSample; r2Sum: the cluster's sum r_j^2 (for G12).
LS_FN rvec2 vt_clusterBound(rvec3 x, rvec3 n, rvec3 lo, rvec3 hi, rvec3 axis, real coneAngle, real r2Min,
                            real r2Sum, rvec3 toEye, real k, bool nearField) {
    const rvec3 c = 0.5 * (lo + hi);
    const rvec3 h = 0.5 * (hi - lo);
    const rvec3 v = c - x;
    // highest point of the box above the tangent plane: exact horizon test, no trigonometry
    const real planeMax = dot(n, v) + dot(abs(n), h);
    if (!(planeMax > 0.0)) return rvec2(0.0, 0.0);
    const rvec3 q = max(abs(v) - h, rvec3(0.0));
    const real d2Min = dot(q, q);
    if (nearField && d2Min < kNearFieldRatio2 * r2Sum) return rvec2(kTreeDescend, kTreeDescend); // G12
    const real r2 = dot(h, h);
    const real dc2 = dot(v, v);
    real cosIMax = 1.0;
    real cosJMax = 1.0;
    real lobeMax = 1.0;
    if (dc2 > r2) {
        const real dc = sqrt(dc2);
        const rvec3 u = v / dc;
        const real beta = asin(min(sqrt(r2 / dc2), 1.0));
        const real angleI = acos(clamp(dot(n, u), -1.0, 1.0)) - beta - kTreeAngleSlack;
        cosIMax = angleI > 0.0 ? max(cos(angleI), 0.0) : 1.0;
        const real angleJ = acos(clamp(-dot(axis, u), -1.0, 1.0)) - beta - coneAngle - kTreeAngleSlack;
        cosJMax = angleJ > 0.0 ? (angleJ < kHalfPi ? cos(angleJ) : 0.0) : 1.0;
        // cos(gamma) = mirror(toLight) . toEye = toLight . mirror(toEye): the lobe's axis is the mirrored eye
        const rvec3 mirrorEye = 2.0 * dot(n, toEye) * n - toEye;
        const real angleS = acos(clamp(dot(mirrorEye, u), -1.0, 1.0)) - beta - kTreeAngleSlack;
        lobeMax = angleS > 0.0 ? ls_cosPow(cos(min(angleS, kHalfPi)), k) : 1.0;
    }
    if (d2Min > 0.0) cosIMax = min(cosIMax, planeMax / sqrt(d2Min));
    const real inv = 1.0 / max(r2Min + d2Min, kTinyLength2);
    return rvec2(cosJMax * cosIMax * inv, cosJMax * lobeMax * inv);
}

// The cluster as one light (see the file comment); moments get the spread through `variance`
// (gather_addSample adds offset^2 w, the caller adds variance w). eps_l is the caller's.
LS_FN GatherSample vt_clusterSample(rvec3 x, rvec3 n, rvec3 p, rvec3 axis, real normalScale, real r2Mean,
                                    real r2Sum, rvec3 flux, rvec3 toEye, real k, real ck) {
    // point model: a cluster is taken only outside its members' near fields (vt_clusterBound)
    GatherSample s = ls_gatherSample(x, n, p, axis, kPi * r2Mean, flux * normalScale, toEye, k, ck, 0.0, false);
    const real scale = r2Mean > 0.0 ? normalScale * r2Sum / r2Mean : 0.0;
    s.weightD = s.weightD * scale;
    s.weightS = s.weightS * scale;
    return s;
}

#endif
