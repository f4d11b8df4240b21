#version 450 core
#include "virtual_area_light.glsl"
// Static content, tolerance mode: per key, a bound B on how much replacing VAL a (last full
// computation) by VAL b (this frame) can change the irradiance at any receiver x in the
// receivers' bounding sphere S (centre c, radius R); per-work-group sums into uPartials.
//
// Derivation. One VAL gives E(x) = phi h(x), h = C_j C_i q with C_j = max(n_l . u, 0),
// C_i = max(-n . u, 0), u = (x - l) / d, d = |x - l|, q = 1 / (pi (r^2 + d^2)) (eq. 3-4,
// lightskin_math.glsl, per colour channel; the guards G1/G2 only act at d ~ 0 or r = 0). With
// D(l) = max(|c - l| - R, 0) <= d for every x in S, and C <= 1:
//   E_b - E_a = (phi_b - phi_a) h_b + phi_a (h_b - h_a),         |h_b| <= 1 / (pi (r_b^2 + D_b^2));
//   h_b - h_a in three steps, each with the others fixed:
//     r^2:  |q(r_b^2) - q(r_a^2)| <= |r_b^2 - r_a^2| / (pi (min r^2 + D_a^2)^2)        (at l_a, n_a)
//     n_l:  |C_j(n_b) - C_j(n_a)| <= |n_b - n_a| (max(., 0) is 1-Lipschitz, |u| = 1) => |n_b - n_a| / (pi (r_b^2 + D_a^2))
//     l:    |grad_l u| = 1/d, so |grad_l h| <= 2 q / d + |grad_l q| <= 4 / (pi d (r^2 + d^2)); on the
//           segment from l_a to l_b, d >= D_s = D_a - |l_b - l_a| (no bound if D_s <= 0).
// Also |E_b - E_a| <= E_a + E_b <= single(a) + single(b) (the cull's bound, 0 when S lies wholly
// behind the VAL's plane). B = min of both; a VAL present on one side only gives single(.).
// A missing VAL (area 0: key without VAL) on both sides gives 0. Channels: max over RGB.
// Near field (guard G12 of lightskin_math.glsl: a VAL within 4 r of a receiver is integrated as an
// area, whose form factor is <= 1 but not <= eq. 3's): where S comes within 4 r of a VAL, single() is
// phi / (pi r^2) (form factor 1) and the Lipschitz bound, derived for eq. 3, is not used.
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Reference { VirtualAreaLight reference[]; };
layout(std430, binding = 1) readonly buffer Current { VirtualAreaLight current[]; };
layout(std430, binding = 2) writeonly buffer Partials { float partials[]; };
uniform uint uKeyCount;
uniform vec4 uReceiverSphere; // centre xyz, radius w (world metres)
shared float partial[256];

const float kPiF = 3.14159265;
const float kInfinity = uintBitsToFloat(0x7F800000u);

bool isValid(VirtualAreaLight v) { return v.positionArea.w > 0.0; }
float maxChannel(vec3 v) { return max(max(v.r, v.g), v.b); }
float distanceToSphere(vec3 l) { return max(length(uReceiverSphere.xyz - l) - uReceiverSphere.w, 0.0); }

// Upper bound of E_v over S (0 if v is invalid or S is wholly behind its plane).
float single(VirtualAreaLight v) {
    if (!isValid(v)) return 0.0;
    const vec3 l = v.positionArea.xyz;
    if (dot(v.normal.xyz, uReceiverSphere.xyz - l) < -uReceiverSphere.w) return 0.0;
    const float dMin = distanceToSphere(l);
    const float r2 = v.positionArea.w / kPiF;
    return maxChannel(abs(v.flux.rgb)) / (kPiF * (dMin * dMin < 16.0 * r2 ? r2 : r2 + dMin * dMin));
}

float changeBound(VirtualAreaLight a, VirtualAreaLight b) {
    const bool validA = isValid(a), validB = isValid(b);
    if (!validA && !validB) return 0.0;
    const float triangle = single(a) + single(b);
    if (!validA || !validB) return triangle;
    const float ra2 = a.positionArea.w / kPiF, rb2 = b.positionArea.w / kPiF, rMin2 = min(ra2, rb2);
    const float dA = distanceToSphere(a.positionArea.xyz), dB = distanceToSphere(b.positionArea.xyz);
    const float shift = length(b.positionArea.xyz - a.positionArea.xyz);
    const float dS = dA - shift;
    // G12's near field, at either end or on the way between them
    if (dA * dA < 16.0 * ra2 || dB * dB < 16.0 * rb2 || dS * dS < 16.0 * max(ra2, rb2) || dS <= 0.0) return triangle;
    const float phiA = maxChannel(abs(a.flux.rgb));
    float lipschitz = maxChannel(abs(b.flux.rgb - a.flux.rgb)) / (kPiF * (rb2 + dB * dB));
    const float radiusTerm = abs(rb2 - ra2) / ((rMin2 + dA * dA) * (rMin2 + dA * dA));
    const float normalTerm = length(b.normal.xyz - a.normal.xyz) / (rb2 + dA * dA);
    const float positionTerm = shift == 0.0 ? 0.0 : (dS > 0.0 ? 4.0 * shift / (dS * (rb2 + dS * dS)) : kInfinity);
    lipschitz += phiA / kPiF * (radiusTerm + normalTerm + positionTerm);
    return min(triangle, lipschitz);
}

void main() {
    const uint t = gl_LocalInvocationID.x;
    const uint key = gl_GlobalInvocationID.x;
    partial[t] = key < uKeyCount ? changeBound(reference[key], current[key]) : 0.0;
    barrier();
    for (uint stride = 128u; stride > 0u; stride >>= 1u) {
        if (t < stride) partial[t] += partial[t + stride];
        barrier();
    }
    if (t == 0u) partials[gl_WorkGroupID.x] = partial[0];
}
