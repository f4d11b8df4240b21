// S(x, n) of IrradianceSensitivity.h; the per-VAL geometry is lightskin_math.glsl's (LightSkinMath.h).
#include "lightskin/src/LightSkinMath.h"

#include <lightskin/gi/reference/IrradianceSensitivity.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <limits>

namespace lightskin::gi::reference {

double irradianceNormalSensitivity(std::span<const VirtualAreaLight> lights, const glm::dvec3& position,
                                   const glm::dvec3& normal) {
    const double length = glm::length(normal);
    if (!(length > 0.0) || !std::isfinite(length)) return std::numeric_limits<double>::quiet_NaN();
    const glm::dvec3 n = normal / length;
    glm::dvec3 v(0.0); // sum over VALs above the horizon of c_j t_j (luminance of M_j w_j / cos(theta_i))
    for (const VirtualAreaLight& l : lights) {
        if (!(l.area > 0.0f)) continue;
        const refmath::DiscTerms t =
            refmath::ls_discTerms(position, n, glm::dvec3(l.position), glm::dvec3(l.normal), double(l.area), false);
        if (!(t.cosI > 0.0)) continue;
        const double luminance = 0.2126 * double(l.flux.x) + 0.7152 * double(l.flux.y) + 0.0722 * double(l.flux.z);
        v += luminance * t.g / refmath::kPi * t.toLight; // M_j w_j = flux g / pi (eq. 3)
    }
    const double e = glm::dot(n, v);
    if (!(e > 0.0)) return std::numeric_limits<double>::infinity();
    return glm::length(v - e * n) / e;
}

} // namespace lightskin::gi::reference
