#pragma once
// Differential rendering (issue 13; Debevec 1998, Knecht et al. 2010): how the virtual objects
// change the light on the real surfaces around them. The real surface seen in the registered
// depth frame gets sparse receiver points (one per receiverStride^2 pixels, position and normal
// as gi::ValGenerator makes them: back-projection, PCL AVERAGE_3D_GRADIENT normal over a
// (2R+1)^2 window, the same edge test); at each receiver in the region the virtual objects can
// affect, the irradiance is gathered twice, without and with the virtual objects:
//
//   E_without = sum_j E_j(x)                       + sum_{lights in room} E_l(x)
//   E_with    = sum_j E_j(x) V_j(x) + sum_k E_k(x) + sum_{lights in room} E_l(x) V_l(x)
//                                                  + sum_{virtual-only lights} E_l(x) V_l(x)
//   dE        = E_with - E_without
// with
//  * E_j: VAL j of the real room (disc form factor, eq. 3/4 of LightSkin: ls_irradiance of
//    gi/shaders/lightskin_math.glsl), V_j = 0 when the segment from x to the disc centre hits a
//    virtual mesh (Embree ray, binary as the centre form factor): the indirect shadow;
//  * E_k: the virtual surfaces as emitters: emittersPerObject discs per object, placed once
//    (area-weighted, stratified) on its triangles, each of area A_obj / N and flux
//    phi_k = rho_d,k E_k A_k, its irradiance E_k = direct light of the scene lights (with
//    ray-traced shadows by the virtual meshes) + the room's VALs (unoccluded, cosine-clamped).
//    Lambertian only (no specular bounce); no visibility between emitter and receiver beyond the
//    two cosines (exact for convex objects, which cannot hide their own front faces);
//  * E_l = I(omega) cos(theta) / d^2 of a scene light; "in room" lights model a light that is
//    really there (the scene's copy of the room's light, as recordings/scenes/orbit.json): they
//    are in the camera image already, so only their shadow by the virtual objects changes it;
//    virtual-only lights add their (shadowed) light. A light that real geometry hides from x
//    (a screen-space shadow ray through the depth frame: a sample of the segment 2 cm .. 0.5 m
//    behind the seen surface) counts in neither E_with nor E_without: the objects cannot take
//    away light that never arrived. Real geometry does not shadow the VALs (they are the surfaces
//    the camera sees, mostly in front of the receivers).
//
// Region: a receiver is gathered when it lies within R_o of some object's bounding-sphere centre
// or when its segment to a light crosses some object's bounding sphere (the direct shadow can
// fall far away). R_o = r_o sqrt(1/eps - 1): beyond it the object (radius r_o) subtends a
// coaxial-disc form factor r^2 / (r^2 + d^2) < eps of the receiver's hemisphere, so neither the
// light it blocks nor the light it reflects can exceed eps of the brightest radiance around
// (falloffFraction eps; 0.01 = one 8-bit code value at about mid grey). Pixels outside the region
// keep dE = 0 and are reported as not affected, so they stay bit for bit as the camera saw them.
//
// Interpolation to pixels: bilinear over the 2x2 surrounding receivers that are valid, in the
// region, and on the same surface (|z_receiver - z_pixel| <= maxDepthChange * z_pixel * (pixel
// distance)), renormalised; no such receiver: the pixel is not affected.
//
// Units and frames: world metres; irradiance W/m^2 in the VALs' flux unit; images BGR like the
// camera image. CPU, double precision per receiver, OpenCV's parallel_for over receiver rows.
// Buffers are sized on the first compute() for one image size and reused (no per-frame allocation).

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>
#include <lightskin/gi/IndirectIllumination.h>
#include <lightskin/gi/ReflectiveShadowMap.h>
#include <lightskin/gi/VirtualAreaLight.h>

#include <glm/vec3.hpp>
#include <opencv2/core/mat.hpp>

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace lightskin::gi {

struct DifferentialSettings {
    int receiverStride = 4;        ///< >= 1: one receiver per stride x stride pixels
    float falloffFraction = 0.01f; ///< eps in (0, 1): region radius R_o = r_o sqrt(1/eps - 1)
    int emittersPerObject = 256;   ///< >= 0 virtual-surface emitter discs per object (0 = no bounce)
    int normalWindowRadius = 2;    ///< >= 1, R of the receiver normal window (ValGenerator's rule)
    float maxDepthChange = 0.03f;  ///< relative depth step counted as an edge (ValGenerator's rule)
    float minDepth = 0.0f;         ///< valid depth: minDepth < z <= maxDepth, metres
    float maxDepth = 1.0e6f;
    double rayEpsilon = 1e-4; ///< shadow rays skip this fraction of the segment at both ends
};
/// Throws lightskin::Error naming the bad field.
void validate(const DifferentialSettings& settings);

/// A scene light as the differential sees it (gi::VirtualLight: intensity W/sr, spot cone uniform).
struct DifferentialLightSource {
    VirtualLight light;
    bool inRoom = true; ///< really in the room (in the camera image): only its shadow changes it
};

/// One receiver point (grid node (i, j) at pixel (i s + s/2, j s + s/2)).
struct DifferentialReceiver {
    glm::dvec3 position{0.0};          ///< world metres
    glm::dvec3 normal{0.0};            ///< unit world, toward the camera
    float depth = 0.0f;                ///< camera z, metres
    bool valid = false;                ///< depth valid, window inside the image and continuous
    bool inRegion = false;             ///< valid and in the region the virtual objects can affect (gathered)
    glm::dvec3 deltaIrradiance{0.0};   ///< dE, RGB W/m^2 (0 unless inRegion)
    glm::dvec3 irradianceWithout{0.0}; ///< E_without, RGB W/m^2 (0 unless inRegion)
};

struct DifferentialImages {
    cv::Mat deltaIrradiance;            ///< CV_32FC3 BGR dE per pixel, 0 where not affected
    cv::Mat irradianceWithout;          ///< CV_32FC3 BGR E_without per pixel, 0 where not affected
    cv::Mat affected;                   ///< CV_8UC1: 255 where the pixel interpolated receivers, else 0
    std::int64_t receiversGathered = 0; ///< receivers in the region
    std::int64_t shadowRays = 0;        ///< Embree rays cast (after the bounding-sphere tests)
};

class DifferentialIrradiance {
public:
    DifferentialIrradiance();
    ~DifferentialIrradiance();
    DifferentialIrradiance(DifferentialIrradiance&&) noexcept;
    DifferentialIrradiance& operator=(DifferentialIrradiance&&) noexcept;

    /// Builds the occluder scene (Embree) and the emitters from the placed virtual objects (their
    /// CPU meshes, world_T_model and diffuse albedo; the GPU views are not used). The meshes need
    /// not outlive the call. Throws lightskin::Error on bad settings, invalid meshes or Embree errors.
    static DifferentialIrradiance create(std::span<const MeshInstance> instances,
                                         const DifferentialSettings& settings = {});

    /// Per frame. `depthMetres`: CV_32FC1 camera z in metres registered to the colour camera
    /// (0, NaN, out of range = missing); `intrinsics` its pinhole (distortion ignored);
    /// `vals`: the room's VALs (the depth VALs of this frame); `lights`: the scene's lights.
    /// Writes `out` (buffers reused when the size matches).
    void compute(const cv::Mat& depthMetres, const CameraIntrinsics& intrinsics, const Pose& world_T_camera,
                 std::span<const VirtualAreaLight> vals, std::span<const DifferentialLightSource> lights,
                 DifferentialImages& out);

    /// The receivers of the last compute(), row-major over the receiver grid.
    std::span<const DifferentialReceiver> receivers() const noexcept;
    int gridWidth() const noexcept;
    int gridHeight() const noexcept;
    /// The emitter discs of the last compute() (flux of that frame), for tests and debug views.
    std::span<const VirtualAreaLight> emitters() const noexcept;
    const DifferentialSettings& settings() const noexcept;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// Copies `count` VALs of a set back from the GPU into `out` (resized; reuses its capacity, so a
/// steady state does not allocate). Needs a current GL context.
void downloadValsInto(const ValSetView& set, std::vector<VirtualAreaLight>& out);

} // namespace lightskin::gi
