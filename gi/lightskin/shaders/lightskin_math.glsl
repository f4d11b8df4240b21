// LightSkin per-interaction math (Lensing & Broll, sections 3.1-3.3), written ONCE in the common
// subset of GLSL 4.50 and C++/GLM: the GPU shaders #include this file with real = float, and the
// double-precision CPU reference (gi/lightskin/src/LightSkinMath.h) #includes the very same file
// with real = double, rvec3 = glm::dvec3. Rules for editing: no `out`/`inout` parameters, no
// struct constructors (assign fields), only 0.0-style real literals, functions prefixed LS_FN.
//
// ---------------------------------------------------------------------------------------------
// Units (decided once for the whole GI core)
// A VAL j is a Lambertian disc of area a_j (m^2, radius r_j^2 = a_j / pi), unit normal n_j and
// radiant flux phi_j (linear RGB, W). Its radiant exitance is M_j = phi_j / a_j = pi * L_e.
// The paper writes eq. 4 as f_r * phi_j * w_j * cos(theta_i) with w_j the dimensionless disc form
// factor of eq. 3; dimensionally that product only yields radiance if phi_j is a flux per unit
// area, i.e. the exitance M_j: the irradiance of a receiver from a Lambertian disc is
// E_j = M_j * F_disk = M_j * w_j * cos(theta_i) (Nusselt / reciprocity). With phi_j taken
// literally, sum_j phi_j w_j would grow linearly with the VAL resolution (phi_j and w_j both scale
// with a_j); with M_j it is resolution independent, and the paper's own remark (4.1) that l'
// decouples from the VAL density only holds this way. So everywhere below "phi" of the paper is
// M_j = phi_j / a_j, evaluated without dividing by a_j:  M_j w_j = phi_j cos(theta_j) / (pi (r_j^2 + d^2)).
//
//   eq. 3   w_j      = r_j^2 cos(theta_j) / (r_j^2 + |x - l_j|^2)            (dimensionless)
//   eq. 4   E_j      = M_j w_j cos(theta_i)  [W/m^2];  L_d = (rho_d / pi) sum_j E_j   [W/(sr m^2)]
//   eq. 5   L_s      = f_s c_k sum_j M_j w_j cos^k(gamma),  c_k = c (k + 1);  c in 1/sr, default
//                      1/(2 pi) (normalised Phong lobe), so f_s is the specular albedo.
//   eq. 7   L'_d = sum E_j (irradiance), L'_s = c_k sum M_j w_j cos^k(gamma) (radiance / f_s),
//           W = sum (eps_l + weight_j), l' = sum l_j (eps_l + weight_j) / W
//   eq.10   L^phong = (rho_d/pi) L''_d cos(theta) / D_d + f_s L''_s cos^k(gamma) / D_s
//   eq.11   L'' = L' D / cos  (renormalisation: eq. 10 reproduces L' at the sparse point)
// A coaxial disc thus gives the exact disc form factor r^2/(r^2+h^2), and a large uniform plane of
// radiance L gives E -> pi L.
//
// Deviations from the paper, all documented where they occur:
//  * D = |x - l'|^2 + rbar^2 instead of |x - l'|^2 (eq. 10/11): the averaged VPL keeps the
//    weighted mean disc r^2 of its VALs, the regularisation the disc form factor (eq. 3) has
//    itself. Equal to the paper when rbar << |x - l'|; finite when l' reaches the receiver.
//  * Both channels are gated to VALs above the receiver's horizon (cos(theta_i) > 0): eq. 5 has
//    no cos(theta_i), but light from below a surface cannot be reflected by it.
//  * Light positions are accumulated relative to the receiver (l_j - x): same l' after adding x,
//    but far better float precision for scenes far from the origin (1e3 m).
//  * eps_l (eq. 7) is the paper's; the GPU adds its terms analytically in the renormalisation
//    (sum_j eps (l_j - x) = eps (sum_j l_j - n x), gather_val_sums.comp) instead of per VAL in the
//    gather loop: identical sums, and independent of VALs the adaptive mode culled. (With eq. 13
//    the eps_l-weighted position of an unlit sparse point moves the interpolated VPL position of
//    its vertices, so culling VALs per VAL would change the image.)
//
// Guards (each keeps results finite and non-negative; error stated):
//  G1 |x - l| -> 0: direction cosines use 1/sqrt(max(d^2 + kCoincident r^2, kTinyLength2)).
//     Relative error 0.5e-12 (r / d)^2: below float precision (6e-8) for d > 3e-3 r, but 1.6e-4
//     at d = 1e-6 m, r = 0.018 m (tests/gi/lightskin: micron_apart); at d = 0 both cosines become 0, so a VAL
//     exactly at the receiver contributes nothing (true value: between 0 and M_j, face-to-face).
//  G2 r^2 + d^2 -> 0: divisor max(r^2 + d^2, kTinyLength2); only reached for zero-area VALs at the
//     receiver, which are invalid anyway (area <= 0 => the VAL is skipped entirely).
//  G3 cos^k underflow (k up to 1e4 and beyond): cos^k = exp(k log(max(cos, kTinyCos))), and 0 when
//     cos <= 0 or k log(cos) < kMinLogPow (-80): absolute error < e^-80 = 1.8e-35, so float never
//     sees denormals or inf*0 (c_k <= 1e5 keeps the product < 2e-30).
//  G4 renormalisation cos -> 0 (eq. 11): divide by max(cos, kMinRenormCos = 1e-3). Exact whenever
//     the averaged VPL is >= 1e-3 (0.06 deg) above the horizon; below, eq. 10 reproduces
//     L' * cos/1e-3 < L' (an underestimate, never more light) and L'' <= 1e3 L' D.
//  G5 W -> 0 (no VAL at all): divide by max(W, kTinyWeight); all sums are 0 so the VPL is 0 at x.
//  G6 W_v = 0 (eq. 13): if all eq.-12 weights vanish (all neighbours equidistant, or
//     the farthest is the only one facing the vertex) fall back to the normal term alone, then to
//     the nearest neighbour with weight 1: model-space geometry only, so never flickers.
//  G7 occlusion: projected sphere area <= kTinyArea => no occlusion; total o clamped to [0, 1].
//  G8 vertex VPL distance floor (eq. 13): eq. 13 averages the VPL positions of up to 8
//     sparse points linearly; where the neighbours' VPLs lie in different directions (thin parts,
//     rims, contact with real surfaces), the averaged l''' can land far nearer the vertex than any
//     gathered VPL was to its own sparse point, and eq. 10's 1/D then multiplies L''' (renormalised
//     for the larger D, eq. 11) many times over: blown pixels that flicker with the depth noise
//     (measured on ICL-NUIM: 20-40x the brute force at the bunny's ears). So a vertex keeps
//     D >= Dmin = min_j (|x_j - l'_j|^2 + rbar_j^2) over its contributing neighbours, by raising its
//     rbar^2 (ls_vertexR2Floor). No change wherever the averaged VPL is at least as far as the
//     nearest gathered one (e.g. one neighbour, or neighbours with equal VPLs). Off: #define
//     LS_VERTEX_DISTANCE_FLOOR 0 (the plain model).
//  G9 extended VPL at the horizon (eq. 10/11): an averaged VPL stands for VALs spread
//     around l' (S_o's radius R, section 3.3), but eq. 10 shades it as a point, so a receiver whose
//     l' lies just below its horizon gets exactly 0 while most of the VALs behind l' are still above
//     it: holes (black pixels) with a hard edge in smoothly lit objects, measured on TUM fr2 and the
//     PCL Kinect TIFFs, where the brute force is smooth. G9 replaces cos(theta) in eq. 10 and 11 by
//     the cosine factor of a uniformly bright sphere of angular radius sigma, sin^2 sigma =
//     R^2 / (R^2 + |l' - x|^2), clipped by the horizon (ls_horizonCos): exactly cos(theta) when l'
//     is more than sigma above the horizon (no change there), 0 only when it is more than sigma
//     below, smooth in between. Renormalisation (eq. 11) uses the same factor, so eq. 10 still
//     reproduces L' at the sparse point. Vertices interpolate R like l' (eq. 13). Needs the second
//     moments (gathered for occlusion, and for G9). Off (horizonSpread 0, R not handed on): points.
//  G10 vertex irradiance cap (eq. 10/13): each sparse point's renormalised VPL reproduces
//     exactly the irradiance E_j it gathered (eq. 11), but only at its own position and normal; the
//     vertex shades the averaged VPL at another position and normal. Where a sparse point sees its
//     light at a grazing angle, eq. 11 has divided by a small cos (down to kMinRenormCos), and a
//     vertex or pixel that sees the averaged l''' less grazing multiplies L''' by up to 1/cos:
//     measured on ICL-NUIM at the bunny's foot ring on the floor, 0.1-2.5 against the brute force's
//     0.06-0.32, flickering with the depth noise. So the shaded diffuse irradiance is capped at the
//     largest E_j (peak RGB channel, occlusion applied) of the vertex's contributing sparse points,
//     interpolated like the VPL (ls_capIrradiance; the colour is kept). Why this is safe: the sparse
//     points are the surface's irradiance samples and eq. 13 a convex combination of them, so an
//     interpolant of the gathered light never exceeds their maximum; only the renormalised
//     point-VPL extrapolation can. The cap binds wrongly only where the receiver's true irradiance
//     exceeds every gathered sample around it: for VALs at distance d from the surface the
//     irradiance varies across the sparse-point spacing h by at most the factor (1 + h/d)^2 (inverse
//     square law), which bounds the cap's error there. Off: cap < 0 (the model before it).
//  G11 buried sparse points (eq. 12/13): a virtual object sunk into a real surface has sparse
//     points under it (behind the registered depth, seen from the camera); no VAL of that surface
//     lights them (they are behind its emitting side), so as neighbours of the vertices above the
//     surface they pull the interpolated light down (speckle on ICL-NUIM along a sunk cube's contact
//     band). Such points get weight 0 in eq. 12/13 (ls_vertexWeightsAboveSurface); a vertex whose
//     neighbours are all buried keeps the paper's weights. Buried: more than 3 sigma(z) of the Kinect
//     noise model behind the depth of its pixel (ls_isBuried); outside the image or on a hole: not
//     buried. A point hidden behind a real object in front of the virtual one counts as buried too
//     (the depth cannot tell "under" from "behind"); its vertex then interpolates its other neighbours.
//     Off: no depth handed in, or LightSkinSettings::buriedSparsePoints false (the model before it).
//  G12 near-field VALs as areas (eq. 3/4): eq. 3 treats a VAL as a point-like disc; beside
//     its rim, 0.1 r above its plane, it gives w cos = 0.0049 where the disc's exact form factor is
//     0.475 (Howell), and a receiver whose tangent plane cuts the disc gets 0 or all of it by where
//     the centre lies. Real surfaces touching virtual objects put thousands of VALs there (black or
//     blown pixels, speckle). So within d < kNearFieldRatio r of a VAL the disc is replaced by a
//     regular kNearFieldSides-gon of the same area, clipped by the receiver's tangent plane, and
//     integrated exactly with Lambert's formula (ls_nearFieldVector): the vector form factor Phi
//     gives w cos(theta_i) = n . Phi (diffuse, eq. 4/7), w = |Phi| and the light direction
//     Phi / |Phi| (glossy lobe, eq. 5). Switch distance: outside it the point model's worst error,
//     over receiver directions and normals, is <= 0.053 r^2 / (r^2 + d^2) (5.3 % of the facing value;
//     at 3 r 9 %, at 2 r 21 %, at 6 r 3.4 %: measured against a 128-gon; it falls like ~0.2 r / d,
//     from receivers whose horizon straddles the disc) and the switch is a step of at most that size.
//     The 32-gon's boundary lies within delta = 0.0032 r of the circle, so its form factor differs
//     from the disc's by at most 2 delta / (pi h) at height h above the disc's plane (the sliver's
//     area times the kernel cos(theta_j) / (pi d^2) <= h / (pi d^3) along the rim): 0.7 % at the
//     rim 0.1 r above the plane (0.475 -> 0.477 measured). Off: nearField false in ls_gatherSample /
//     ls_irradiance (GLSL: #define LS_NEAR_FIELD 0), the model before it. A cluster of VALs within
//     that distance is never taken as one light (vt_clusterBound).
// ---------------------------------------------------------------------------------------------

#ifndef LIGHTSKIN_MATH_GLSL
#define LIGHTSKIN_MATH_GLSL

#ifndef LS_VERTEX_DISTANCE_FLOOR
#define LS_VERTEX_DISTANCE_FLOOR 1
#endif
// G12 in the shaders: 1 = near-field VALs as areas (passed as ls_gatherSample's nearField).
#ifndef LS_NEAR_FIELD
#define LS_NEAR_FIELD 1
#endif

#ifndef LS_CPP
#define real float
#define rvec2 vec2
#define rvec3 vec3
#define LS_FN
#endif

const real kPi = 3.14159265358979323846;
const real kCoincident = 1.0e-12;   // G1, relative to r^2
const real kTinyLength2 = 1.0e-36;  // G1/G2, m^2 (a normal float)
const real kTinyCos = 1.0e-30;      // G3
const real kMinLogPow = -80.0;      // G3
const real kMinRenormCos = 1.0e-3;  // G4
const real kMinSpreadSin2 = 1.0e-6; // G9
const real kTinyWeight = 1.0e-35;   // G5
const real kTinyArea = 1.0e-30;     // G7 (unit-circle area, dimensionless)
const int kNeighbours = 8;          // eq. 12/13
const real kNearFieldRatio2 = 16.0; // G12: (switch distance / r)^2, i.e. d < 4 r
const int kNearFieldSides = 32;     // G12: polygon sides
// G12: circumradius / r of the regular 32-gon of area pi r^2 (sqrt(2 pi / (N sin(2 pi / N)))), and
// the rotation by 2 pi / N that steps from one vertex to the next
const real kNearFieldCircumradius = 1.0032220804984129;
const real kNearFieldCos = 0.98078528040323044913;
const real kNearFieldSin = 0.19509032201612826785;

// G3: cos^k with k >= 1, 0 for cos <= 0, no underflow to denormals.
LS_FN real ls_cosPow(real c, real k) {
    if (!(c > 0.0)) return 0.0;
    const real e = k * log(max(min(c, 1.0), kTinyCos));
    return e < kMinLogPow ? 0.0 : exp(e);
}

// Phong: cosine between the mirror direction of the light and the eye direction (eq. 5).
LS_FN real ls_cosGamma(rvec3 n, rvec3 toLight, rvec3 toEye) {
    const rvec3 mirror = 2.0 * dot(n, toLight) * n - toLight;
    return dot(mirror, toEye);
}

// Unit vector from p to the eye (0 vector if p is at the eye).
LS_FN rvec3 ls_toEye(rvec3 p, rvec3 eye) {
    const rvec3 v = eye - p;
    return v * inversesqrt(max(dot(v, v), kTinyLength2));
}

// One VAL seen from one receiver (eq. 3, 4, 5, 7).
struct GatherSample {
    rvec3 irradiance; // E_j = M_j w_j cos(theta_i), W/m^2              (eq. 4 / L'_d term of eq. 7)
    real weightD;     // eps_l + w_j cos(theta_i)                        (eq. 7)
    rvec3 glossy;     // c_k M_j w_j cos^k(gamma), W/(sr m^2) per f_s     (eq. 5 / L'_s term of eq. 7)
    real weightS;     // eps_l + w_j cos^k(gamma)                         (eq. 7)
    rvec3 offset;     // l_j - x, metres
    real r2;          // r_j^2 = a_j / pi, m^2
};

// Tangent t of a right-handed orthonormal frame (t, b, n) (Duff et al. 2017), eq. 14's t.
LS_FN rvec3 ls_tangent(rvec3 n) {
    const real s = n.z >= 0.0 ? 1.0 : -1.0;
    const real a = -1.0 / (s + n.z);
    const real c = n.x * n.y * a;
    return rvec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
}
LS_FN rvec3 ls_binormal(rvec3 n) {
    const real s = n.z >= 0.0 ? 1.0 : -1.0;
    const real a = -1.0 / (s + n.z);
    const real c = n.x * n.y * a;
    return rvec3(c, s + n.y * n.y * a, -n.y);
}

// G12: atan(s, c) for s >= 0 (an angle in [0, pi]) to ~1e-9 relative, with + - * / only: GLSL's
// atan has no precision requirement (llvmpipe's differs from the C library's by ~1e-4 relative), and
// the polygon's form factor is a sum of 32 such angles that cancel down to a small result.
// Reductions: octant (atan(a) = pi/2 - atan(1/a)), then atan(a) = pi/6 + atan((sqrt(3) a - 1) /
// (a + sqrt(3))) above tan(pi/12), leaving |a| <= 0.268 for the series up to a^11 (error < a^13 / 13
// = 2e-9).
LS_FN real ls_angle(real s, real c) {
    const real ac = abs(c);
    const bool swap = s > ac;
    real a = (swap ? ac : s) / max(swap ? s : ac, kTinyLength2);
    const bool shift = a > 0.26794919243112270;
    a = shift ? (1.73205080756887729 * a - 1.0) / (a + 1.73205080756887729) : a;
    const real a2 = a * a;
    real t = a * (1.0 + a2 * (-1.0 / 3.0 + a2 * (1.0 / 5.0 + a2 * (-1.0 / 7.0 + a2 * (1.0 / 9.0 - a2 / 11.0)))));
    t = shift ? 0.52359877559829887 + t : t;
    t = swap ? 1.57079632679489662 - t : t;
    return c < 0.0 ? kPi - t : t;
}

// G12: Lambert's edge term of a polygon seen from the origin: the angle between a and b times the
// unit normal of their plane (0 for a degenerate edge).
LS_FN rvec3 ls_edgeVector(rvec3 a, rvec3 b) {
    const rvec3 c = cross(a, b);
    const real s = length(c);
    return s > 0.0 ? c * (ls_angle(s, dot(a, b)) / s) : rvec3(0.0);
}

// G12: the vector form factor Phi of a VAL (offset = l - x, unit normal nl, r2 = r^2) at a receiver
// with unit normal n, the VAL as a regular kNearFieldSides-gon of area pi r^2 clipped by the
// receiver's tangent plane: Phi = -(1 / 2 pi) sum_edges beta_e gamma_e (Lambert; the vertices run
// counter-clockwise about nl), and the form factor is n . Phi >= 0. 0 behind the VAL (one-sided).
// The clipped polygon is streamed: edges above the plane, the parts of the crossing edges above
// it, and the chord in the plane from where the boundary leaves to where it comes back. sides:
// kNearFieldSides, or 0 for a VAL outside the near field (0 vector). A run-time trip count on
// purpose: llvmpipe runs both sides of a divergent `if` under a mask, but leaves a loop as soon as
// no lane iterates, so a shader whose VALs are all far skips the polygon (measured: with the loop
// behind an `if` alone, the brute force took 4-5x as long on a scene without near-field pairs).
LS_FN rvec3 ls_nearFieldVector(rvec3 offset, rvec3 n, rvec3 nl, real r2, int sides) {
    rvec3 sum = rvec3(0.0);
    rvec3 leave = rvec3(0.0);
    rvec3 enter = rvec3(0.0);
    rvec3 t = rvec3(0.0);
    rvec3 b = rvec3(0.0);
    rvec3 p = rvec3(0.0);
    bool left = false;
    bool entered = false;
    real c = 1.0;
    real s = 0.0;
    real hp = 0.0;
    // k = 0 sets up the frame and the first vertex inside the loop, so that far VALs pay nothing
    for (int k = 0; k <= sides && sides > 0; ++k) {
        if (k == 0) {
            const real radius = sqrt(r2) * kNearFieldCircumradius;
            t = ls_tangent(nl) * radius;
            b = ls_binormal(nl) * radius;
            p = offset + t;
            hp = dot(n, p);
        } else {
            const real cNext = c * kNearFieldCos - s * kNearFieldSin;
            s = s * kNearFieldCos + c * kNearFieldSin;
            c = cNext;
            const rvec3 q = k == sides ? offset + t : offset + c * t + s * b; // closes exactly
            const real hq = dot(n, q);
            if (hp >= 0.0 && hq >= 0.0) {
                sum += ls_edgeVector(p, q);
            } else if (hp >= 0.0) {
                leave = p + (q - p) * (hp / (hp - hq));
                left = true;
                sum += ls_edgeVector(p, leave);
            } else if (hq >= 0.0) {
                enter = p + (q - p) * (hp / (hp - hq));
                entered = true;
                sum += ls_edgeVector(enter, q);
            }
            p = q;
            hp = hq;
        }
    }
    if (left && entered) sum += ls_edgeVector(leave, enter);
    return -dot(nl, offset) > 0.0 ? sum * (-1.0 / (2.0 * kPi)) : rvec3(0.0); // one-sided
}

// eq. 3 geometry of one VAL (l, nl, area) seen from a receiver (x, n), with guards G1, G2, G12.
struct DiscTerms {
    rvec3 offset;  // l - x
    rvec3 toLight; // unit (G1-regularised); G12: the direction of Phi
    real r2;       // a / pi, 0 for an invalid VAL
    real cosI;     // max(cos(theta_i), 0)
    real g;        // cos(theta_j) / (r^2 + d^2): w = r^2 g, M w = flux g / pi; G12: |Phi| / r^2
};

// nearField: G12 for receivers within kNearFieldRatio r (false: the point model everywhere).
LS_FN DiscTerms ls_discTerms(rvec3 x, rvec3 n, rvec3 l, rvec3 nl, real area, bool nearField) {
    DiscTerms t;
    t.offset = l - x;
    t.r2 = area > 0.0 ? area / kPi : 0.0;
    const real d2 = dot(t.offset, t.offset);
    // G12, outside any `if`: the trip count (0 far away) is what lets llvmpipe skip the polygon
    const bool near = nearField && d2 < kNearFieldRatio2 * t.r2;
    const rvec3 phi = ls_nearFieldVector(t.offset, n, nl, t.r2, near ? kNearFieldSides : 0);
    const real invLength = inversesqrt(max(d2 + kCoincident * t.r2, kTinyLength2)); // G1
    t.toLight = t.offset * invLength;
    t.cosI = max(dot(n, t.toLight), 0.0);
    const real cosJ = max(-dot(nl, t.toLight), 0.0);
    t.g = cosJ / max(t.r2 + d2, kTinyLength2);                                     // G2
    if (near) {
        // G12: w cos(theta_i) = n . Phi = |Phi| cos(theta_i) with theta_i the angle to Phi
        const real length2 = dot(phi, phi);
        const real invPhi = length2 > 0.0 ? inversesqrt(length2) : 0.0;
        t.toLight = length2 > 0.0 ? phi * invPhi : t.toLight;
        t.cosI = max(dot(n, t.toLight), 0.0);
        t.g = length2 * invPhi / t.r2;
    }
    return t;
}

// x, n: receiver position and unit normal; l, nl, area, flux: the VAL; toEye: unit vector to the
// eye; k: Phong exponent; ck = c (k+1); epsL: eps_l; nearField: guard G12 (GLSL: LS_NEAR_FIELD != 0).
// An invalid VAL (area <= 0 or NaN) gives all 0.
LS_FN GatherSample ls_gatherSample(rvec3 x, rvec3 n, rvec3 l, rvec3 nl, real area, rvec3 flux, rvec3 toEye,
                                   real k, real ck, real epsL, bool nearField) {
    const DiscTerms t = ls_discTerms(x, n, l, nl, area, nearField);
    const bool valid = area > 0.0;
    GatherSample s;
    s.offset = t.offset;
    s.r2 = t.r2;
    const real w = t.r2 * t.g;                                                    // eq. 3
    const rvec3 mw = flux * (t.g / kPi);                                          // M_j w_j
    const real lobe = t.cosI > 0.0 ? ls_cosPow(ls_cosGamma(n, t.toLight, toEye), k) : 0.0;
    s.irradiance = valid ? mw * t.cosI : rvec3(0.0);
    s.glossy = valid ? mw * (ck * lobe) : rvec3(0.0);
    s.weightD = valid ? epsL + w * t.cosI : 0.0;
    s.weightS = valid ? epsL + w * lobe : 0.0;
    return s;
}

// Irradiance E_j = M_j w_j cos(theta_i) alone (eq. 3, 4): the diffuse-only brute force.
LS_FN rvec3 ls_irradiance(rvec3 x, rvec3 n, rvec3 l, rvec3 nl, real area, rvec3 flux, bool nearField) {
    const DiscTerms t = ls_discTerms(x, n, l, nl, area, nearField);
    return area > 0.0 ? flux * (t.g / kPi * t.cosI) : rvec3(0.0);
}

// Brute force (eq. 2 with 4 and 5) for one VAL at one pixel: reflected radiance toward the eye.
LS_FN rvec3 ls_bruteForceRadiance(GatherSample s, rvec3 rhoD, rvec3 fs) {
    return rhoD * (s.irradiance / kPi) + fs * s.glossy;
}

// An averaged, renormalised VPL (eq. 11) with its occlusion sphere S_o (section 3.3).
struct Vpl {
    rvec3 radiance;     // L'' (diffuse: irradiance * m^2; glossy: radiance/f_s * m^2)
    real r2;            // rbar^2, m^2
    rvec3 position;     // l', world metres
    real sphereRadius;  // radius of S_o, metres
};

// G9: the cosine factor of a uniformly bright sphere of angular radius sigma (sin2 = sin^2 sigma)
// whose centre lies at cos(theta) from the normal, clipped by the horizon, divided by the unclipped
// pi sin^2 sigma (Snyder 1996, "Area light sources for real-time graphics", sphere irradiance).
LS_FN real ls_horizonCos(real cosT, real sin2) {
    if (!(sin2 > 0.0) || cosT * cosT > sin2) return max(cosT, 0.0);
    const real s2 = min(sin2, 0.999999);
    const real sinT = sqrt(max(1.0 - cosT * cosT, 0.0));
    const real x = sqrt(1.0 / s2 - 1.0);
    const real y = clamp(-x * cosT / max(sinT, 1.0e-30), -1.0, 1.0);
    const real sy = sinT * sqrt(max(1.0 - y * y, 0.0));
    const real e = (cosT * acos(y) - x * sy) * s2 + atan(sy, x);
    return max(e / (kPi * s2), 0.0);
}

// G9: sin^2 of the angular radius of the VPL's spread (S_o, radius R) seen at squared distance d2;
// 0 below kMinSpreadSin2 (sigma < 1e-3 rad, the scale of G4): S_o's radius is the square root of a
// difference of two sums ~|l' - x|^2, whose float rounding (~1e-7 relative) alone makes sin^2 ~ 1e-7.
LS_FN real ls_spreadSin2(real radius, real d2) {
    const real r2 = radius * radius;
    const real s2 = r2 / max(r2 + d2, kTinyLength2);
    return s2 > kMinSpreadSin2 ? s2 : 0.0;
}

// eq. 10, diffuse factor of one VPL at p with normal n: L'' cos(theta) / D (irradiance, W/m^2).
LS_FN rvec3 ls_applyDiffuse(Vpl v, rvec3 p, rvec3 n) {
    const rvec3 o = v.position - p;
    const real d2 = dot(o, o);
    const real cosT = ls_horizonCos(dot(n, o) * inversesqrt(max(d2 + kCoincident * v.r2, kTinyLength2)),
                                    ls_spreadSin2(v.sphereRadius, d2));
    return v.radiance * (cosT / max(d2 + v.r2, kTinyLength2));
}

// eq. 10, glossy factor of one VPL at p: L'' cos^k(gamma) / D (radiance per unit f_s), gated
// to VPLs above the horizon like the gather.
LS_FN rvec3 ls_applyGlossy(Vpl v, rvec3 p, rvec3 n, rvec3 toEye, real k) {
    const rvec3 o = v.position - p;
    const real d2 = dot(o, o);
    const rvec3 toLight = o * inversesqrt(max(d2 + kCoincident * v.r2, kTinyLength2));
    const real lobe = dot(n, toLight) > 0.0 ? ls_cosPow(ls_cosGamma(n, toLight, toEye), k) : 0.0;
    return v.radiance * (lobe / max(d2 + v.r2, kTinyLength2));
}

// eq. 8-11 for the diffuse channel. sumL = L'_d, sumOffset = sum (l_j - x) weight_j, sumW = W_d,
// sumR2 = sum r_j^2 weight_j, sumMoment = sum (l_j - x)^2 weight_j per axis (for S_o).
LS_FN Vpl ls_renormaliseDiffuse(rvec3 sumL, rvec3 sumOffset, real sumW, real sumR2, rvec3 sumMoment, rvec3 x,
                                rvec3 n, real horizonSpread) {
    const real invW = 1.0 / max(sumW, kTinyWeight);                 // G5
    const rvec3 mean = sumOffset * invW;
    Vpl v;
    v.r2 = max(sumR2 * invW, 0.0);
    v.position = x + mean;
    const rvec3 variance = max(sumMoment * invW - mean * mean, rvec3(0.0));
    v.sphereRadius = sqrt(max(max(variance.x, variance.y), variance.z)); // radius = max sigma_i
    const real d2 = dot(mean, mean);
    const real cosT = ls_horizonCos(dot(n, mean) * inversesqrt(max(d2 + kCoincident * v.r2, kTinyLength2)),
                                    horizonSpread * ls_spreadSin2(v.sphereRadius, d2));
    v.radiance = sumL * (max(d2 + v.r2, kTinyLength2) / max(cosT, kMinRenormCos)); // eq. 11, G4
    return v;
}

// eq. 8-11 for the glossy channel; sumMoment2 = sum |l_j - x|^2 weight_j (scalar), S_o radius
// sqrt(trace / 3) (the isotropic equivalent of max sigma_i).
LS_FN Vpl ls_renormaliseGlossy(rvec3 sumL, rvec3 sumOffset, real sumW, real sumR2, real sumMoment2, rvec3 x,
                               rvec3 n, rvec3 toEye, real k) {
    const real invW = 1.0 / max(sumW, kTinyWeight);
    const rvec3 mean = sumOffset * invW;
    Vpl v;
    v.r2 = max(sumR2 * invW, 0.0);
    v.position = x + mean;
    const real d2 = dot(mean, mean);
    v.sphereRadius = sqrt(max(sumMoment2 * invW - d2, 0.0) / 3.0);
    const rvec3 toLight = mean * inversesqrt(max(d2 + kCoincident * v.r2, kTinyLength2));
    const real lobe = dot(n, toLight) > 0.0 ? ls_cosPow(ls_cosGamma(n, toLight, toEye), k) : 0.0;
    v.radiance = sumL * (max(d2 + v.r2, kTinyLength2) / max(lobe, kMinRenormCos));
    return v;
}

// Occlusion target of one sparse point (section 3.3): S_o double-projected to a quad.
struct OcclusionTarget {
    rvec2 centre;  // eq. 14
    real side;     // sqrt(pi F) with F of eq. 3 at cos(theta_j) = 1
    real area;     // pi F (area of the projected sphere on the unit circle)
    real distance; // |c - x|
    real radius;   // radius of S_o
};

LS_FN OcclusionTarget ls_occlusionTarget(rvec3 x, rvec3 n, rvec3 t, rvec3 b, rvec3 c, real radius) {
    OcclusionTarget o;
    const rvec3 v = c - x;
    const real d2 = dot(v, v);
    const rvec3 u = v * inversesqrt(max(d2, kTinyLength2));
    const real r2 = radius * radius;
    const real cosI = max(dot(n, u), 0.0);
    o.area = kPi * cosI * r2 / max(r2 + d2, kTinyLength2);
    o.side = sqrt(o.area);
    o.centre = rvec2(dot(u, t), dot(u, b));
    o.distance = sqrt(d2);
    o.radius = radius;
    return o;
}

// Fraction of S_o one occluder disc (y, ny, ry) hides from x, scaled linearly to zero for
// occluders between the near side and the centre of S_o (section 3.3). Not clamped: the caller
// sums over occluders ("double occlusion" as in the paper) and clamps the total to [0, 1].
LS_FN real ls_occluderAmount(OcclusionTarget target, rvec3 x, rvec3 n, rvec3 t, rvec3 b, rvec3 y, rvec3 ny, real ry) {
    if (!(target.area > kTinyArea)) return 0.0;                 // G7
    const rvec3 v = y - x;
    const real d2 = dot(v, v);
    if (!(d2 > kTinyLength2)) return 0.0;                        // the point itself
    const rvec3 u = v * inversesqrt(d2);
    const real cosI = dot(n, u);
    if (!(cosI > 0.0)) return 0.0;                               // below the horizon: cannot occlude
    const real r2 = ry * ry;
    const real area = kPi * abs(dot(ny, u)) * r2 / max(r2 + d2, kTinyLength2) * cosI; // pi F_disk, eq. 3
    const real side = sqrt(area);
    const rvec2 centre = rvec2(dot(u, t), dot(u, b));                                // eq. 14
    const real ox = max(min(target.centre.x + 0.5 * target.side, centre.x + 0.5 * side) -
                            max(target.centre.x - 0.5 * target.side, centre.x - 0.5 * side), 0.0);
    const real oy = max(min(target.centre.y + 0.5 * target.side, centre.y + 0.5 * side) -
                            max(target.centre.y - 0.5 * target.side, centre.y - 0.5 * side), 0.0);
    const real dy = sqrt(d2);
    const real depth = clamp((target.distance - dy) / max(target.radius, 1.0e-30), 0.0, 1.0);
    return ox * oy / target.area * depth;
}

// G8: rbar^2 of a vertex VPL at `position` for the vertex at `vertex`, given the smallest D of its
// contributing sparse points' VPLs (minD).
LS_FN real ls_vertexR2Floor(real r2, rvec3 vertex, rvec3 position, real minD) {
#if LS_VERTEX_DISTANCE_FLOOR
    const rvec3 o = position - vertex;
    return max(r2, minD - dot(o, o));
#else
    return r2 + 0.0 * (minD + dot(position, vertex));
#endif
}

// G10: the largest RGB channel of an irradiance (the cap's scalar).
LS_FN real ls_peakChannel(rvec3 e) {
    return max(max(e.x, e.y), e.z);
}

// G10: irradiance e scaled down (colour kept) so that its peak channel is at most cap; cap < 0 =
// no cap.
LS_FN rvec3 ls_capIrradiance(rvec3 e, real cap) {
    const real peak = ls_peakChannel(e);
    return cap >= 0.0 && peak > cap ? e * (cap / peak) : e;
}

struct VertexWeights {
    real w[kNeighbours]; // normalised: sum = 1 (eq. 13's 1/W_v applied)
};

// eq. 12/13 weights of the 8 neighbours with guard G6, over the neighbours with kept[j] (the others get
// weight 0). dist: |v - x_j|; cosN: n_v . n_x_j; unique: false for repeats of an earlier index (sets
// with < 8 points). d_max of eq. 12 stays the farthest of all unique neighbours, so the kept ones keep
// their relative weights; G6b takes the nearest kept neighbour. At least one unique neighbour must be
// kept (ls_vertexWeightsAboveSurface ensures it).
LS_FN VertexWeights ls_vertexWeightsOf(real dist[kNeighbours], real cosN[kNeighbours], bool unique[kNeighbours],
                                       bool kept[kNeighbours]) {
    VertexWeights r;
    real dMax = 0.0;
    for (int j = 0; j < kNeighbours; ++j)
        if (unique[j]) dMax = max(dMax, dist[j]);
    real total = 0.0;
    for (int j = 0; j < kNeighbours; ++j) {
        // eq. 12: (1 - d_j / d_max) (n_v . n_x,j), the dot product clamped to [0, 1]
        const real distanceTerm = dMax > 0.0 ? max(1.0 - dist[j] / dMax, 0.0) : 1.0;
        r.w[j] = unique[j] && kept[j] ? distanceTerm * clamp(cosN[j], 0.0, 1.0) : 0.0;
        total += r.w[j];
    }
    if (!(total > 0.0)) { // G6a: normal term alone
        total = 0.0;
        for (int j = 0; j < kNeighbours; ++j) {
            r.w[j] = unique[j] && kept[j] ? clamp(cosN[j], 0.0, 1.0) : 0.0;
            total += r.w[j];
        }
    }
    if (!(total > 0.0)) { // G6b: the nearest (kept) neighbour
        int nearest = -1;
        for (int j = 0; j < kNeighbours; ++j) {
            r.w[j] = 0.0;
            if (nearest < 0 && unique[j] && kept[j]) nearest = j;
        }
        r.w[max(nearest, 0)] = 1.0;
        total = 1.0;
    }
    for (int j = 0; j < kNeighbours; ++j) r.w[j] = r.w[j] / total;
    return r;
}

// eq. 12/13 weights of the 8 neighbours with guard G6 (the paper's rule: every neighbour counts).
LS_FN VertexWeights ls_vertexWeights(real dist[kNeighbours], real cosN[kNeighbours], bool unique[kNeighbours]) {
    bool kept[kNeighbours];
    for (int j = 0; j < kNeighbours; ++j) kept[j] = true;
    return ls_vertexWeightsOf(dist, cosN, unique, kept);
}

// G11: Kinect v1 axial depth noise sigma(z), metres, z metres along the optical axis (Nguyen, Izadi,
// Lovell, 3DIMPVT 2012; surfaces at 10-60 degrees). The same model and 3 sigma margin as the VAL
// occupancy cull (gi::ValOccupancyCull, docs/LIGHTSKIN.md).
LS_FN real ls_depthNoiseSigma(real z) {
    return 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
}

// G11: a point at camera depth pointZ lies under the real surface when it is more than 3 sigma(realZ)
// behind the registered depth realZ of its pixel (metres). realZ <= 0 or NaN (a hole) and NaN pointZ:
// not buried. Why 3 sigma of the raw sensor: the bilateral filter (capture/DepthFilter.h) only averages
// noise down, so raw 3 sigma is conservative: a point on the surface is flagged with probability
// < 0.14 % (one-sided Gaussian); the nearest-pixel lookup adds at most half a pixel of depth slope,
// 0.87 z / f on surfaces up to 60 degrees (0.3 of the margin at 1 m, less elsewhere in 0.5-4 m).
LS_FN bool ls_isBuried(real pointZ, real realZ) {
    return realZ > 0.0 && pointZ > realZ + 3.0 * ls_depthNoiseSigma(realZ);
}

// G11: pixel coordinates (column, row; pixel centres at integers) of a camera-frame point (OpenCV
// frame: x right, y down, z forward; fy may be negative); pc.z > 0.
LS_FN rvec2 ls_projectToPixel(rvec3 pc, real fx, real fy, real cx, real cy) {
    return rvec2(fx * pc.x / pc.z + cx, fy * pc.y / pc.z + cy);
}

// G11 (eq. 12/13): the weights with the neighbours buried under the real surface left out
// (weight 0): a sparse point under a real floor gathers no light from it (its VALs face away from it),
// so as a neighbour it darkens the vertices above the surface. A vertex whose neighbours are all
// buried keeps the paper's weights (nothing better is known there).
LS_FN VertexWeights ls_vertexWeightsAboveSurface(real dist[kNeighbours], real cosN[kNeighbours],
                                                 bool unique[kNeighbours], bool buried[kNeighbours]) {
    bool kept[kNeighbours];
    bool anyKept = false;
    for (int j = 0; j < kNeighbours; ++j) {
        kept[j] = !buried[j];
        anyKept = anyKept || (unique[j] && kept[j]);
    }
    if (!anyKept) return ls_vertexWeights(dist, cosN, unique);
    return ls_vertexWeightsOf(dist, cosN, unique, kept);
}

#endif
