#pragma once
// A Lambertian room rendered in closed form, independent of roomlight's code: the truth of the light-estimation
// tests. World: z up, metres; the room is the box [0, size.x] x [0, size.y] x [0, size.z] with floating spheres.
// Outgoing radiance of a surface point x with normal n and albedo rho (direct light + ambient, no interreflection):
//   L(x) = rho / pi * E(x, n),  E = sum_point I max(0, n.l) / d^2 V + sum_dir E0 max(0, n.d) V
//                                  + sum_area quadrature of L_e cos_e cos_x / d^2 V dA + pi a + 2 pi / 3 b n_z,
// V the visibility against the spheres (the lights are inside the convex room, so the walls never occlude them),
// the ambient sky a radiance a + b w_z from direction w (not occluded, as in synth/). The camera pixel is
// exposure * gain_c * L (1 + noise), sRGB-encoded to 8 bits (clipped at 255), depth rounded to millimetres.

#include <lightskin/core/Pose.h>
#include <lightskin/core/RgbdFrame.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <optional>
#include <vector>

namespace lightskin::roomlight::test {

struct PointLight {
    glm::dvec3 position{0.0};
    glm::dvec3 intensity{0.0}; ///< irradiance at 1 m facing the light, camera units
};
struct DirectionalLight {
    glm::dvec3 towardLight{0.0, 0.0, 1.0}; ///< unit
    glm::dvec3 irradiance{0.0};            ///< E0 facing the light
};
struct RectangleLight {
    glm::dvec3 centre{0.0}, facing{0.0, 0.0, -1.0}, axisU{1.0, 0.0, 0.0}; ///< facing and axisU unit, orthogonal
    double width = 0.5, height = 0.5;
    glm::dvec3 radiance{0.0};
};
struct Sphere {
    glm::dvec3 centre{0.0};
    double radius = 0.3;
    glm::dvec3 albedo{0.5};
};

struct SyntheticRoom {
    glm::dvec3 size{4.0, 5.0, 3.0};
    /// Albedo of the floor (z = 0), ceiling, and the four walls.
    glm::dvec3 floorAlbedo{0.5}, ceilingAlbedo{0.5}, wallAlbedo{0.5};
    std::vector<Sphere> spheres;
    std::vector<PointLight> pointLights;
    std::vector<DirectionalLight> directionalLights;
    std::vector<RectangleLight> rectangleLights; ///< drawn as emitters on whatever surface they lie on
    double skyConstant = 0.0, skyGradient = 0.0; ///< ambient radiance a + b w_z

    /// Irradiance at a point with normal n, exact (area lights by a 'subdivisions'^2 midpoint quadrature).
    glm::dvec3 irradiance(const glm::dvec3& position, const glm::dvec3& normal, int subdivisions) const;
    /// What the camera sees along a ray: radiance and the hit point (nullopt outside the room).
    struct Hit {
        glm::dvec3 position{0.0}, normal{0.0}, albedo{0.0};
        bool onEmitter = false;
        glm::dvec3 emitted{0.0};
    };
    std::optional<Hit> trace(const glm::dvec3& origin, const glm::dvec3& direction) const;
    bool visible(const glm::dvec3& from, const glm::dvec3& to) const;
};

struct CameraShot {
    Pose world_T_camera;
    double exposure = 1.0;
    glm::dvec3 whiteBalance{1.0}; ///< per-channel gain on top of the exposure
    double relativeNoise = 0.0;   ///< Gaussian, sigma relative to the pixel value
    std::uint32_t noiseSeed = 1;
    double timeSeconds = 0.0;
};

/// OpenCV camera at `eye` looking at `target`, world up +z.
Pose lookAt(const glm::dvec3& eye, const glm::dvec3& target);
/// 640x480, fx = fy = 525, no distortion (the Kinect v1 default).
CameraIntrinsics testIntrinsics();
/// Renders one registered frame (BGR sRGB colour, millimetre depth).
RgbdFrame render(const SyntheticRoom& room, const CameraShot& shot, const CameraIntrinsics& intrinsics);

/// The order-2 SH projection of the room's irradiance at `position` (all normals), by a 256 x 512 midpoint
/// quadrature over the sphere with its own SH basis (not roomlight's): E_k = integral E(n) Y_k(n) dn.
std::array<glm::dvec3, 9> projectIrradiance(const SyntheticRoom& room, const glm::dvec3& position);

} // namespace lightskin::roomlight::test
