#pragma once
// Differential rendering (Debevec 1998, Knecht et al. 2010): how the virtual objects
// change the light on the real surfaces around them. At sparse receivers of the depth frame the
// irradiance is gathered without and with the virtual objects (their shadows of the room's VALs and
// of the scene lights, their own bounce) and dE = E_with - E_without is interpolated to the pixels;
// pixels outside the region the objects can affect stay bit for bit as the camera saw them.
// Receivers are gathered adaptively: the corners of cells of refineCell x refineCell receivers first, the
// inside of a cell only where dE / E_without varies over it, near the objects or across depth edges;
// elsewhere interpolated from the corners. The scene lights' shadows are sharp: each pixel tests its own.
// The terms, the region bound, the refinement and the interpolation: docs/LIGHTSKIN.md, "Differential
// irradiance".
//
// Units and frames: world metres; irradiance W/m^2 in the VALs' flux unit; images BGR like the
// camera image. CPU, OpenCV's parallel_for: the VAL and emitter sums (eq. 3/4) with CpuLightSkin's
// SIMD gather kernel (float sums), the indirect shadow's pairs (VAL, or merged shadow disc, and
// receiver) found through clusters of them and traced with Embree, the rest in double. Results do
// not depend on the thread count. Buffers are sized on the first compute() for one image size and
// VAL count and reused (no per-frame allocation once grown).

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>
#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gi/common/ReflectiveShadowMap.h>
#include <lightskin/gi/common/VirtualAreaLight.h>

#include <glm/vec3.hpp>
#include <opencv2/core/mat.hpp>

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace lightskin::gi {

struct DifferentialSettings {
    /// One receiver per stride x stride pixels, 1..64; 0: automatic, width / 80 (4 at 320, 8 at 640), >= 2.
    int receiverStride = 0;
    float falloffFraction = 0.01f; ///< eps in (0, 1): region radius R_o = r_o sqrt(1/eps - 1)
    int emittersPerObject = 256;   ///< >= 0 virtual-surface emitter discs per object (0 = no bounce)
    int normalWindowRadius = 2;    ///< >= 1, R of the receiver normal window (ValGenerator's rule)
    float maxDepthChange = 0.03f;  ///< relative depth step counted as an edge (ValGenerator's rule)
    float minDepth = 0.0f;         ///< valid depth: minDepth < z <= maxDepth, metres
    float maxDepth = 1.0e6f;
    double rayEpsilon = 1e-4; ///< shadow rays skip this fraction of the segment at both ends
    /// Receivers per side of the largest adaptive cell, a power of two in 1..64 (1: every receiver in the
    /// region is gathered).
    int refineCell = 4;
    /// > 0: a cell whose corners' dE / E_without (per channel) spread by more than this is gathered
    /// receiver by receiver; it bounds the interpolated pixels' relative error (docs/LIGHTSKIN.md).
    float refineTolerance = 0.01f;
    /// VALs (consecutive in their spatial order, a power of two in 1..16) whose indirect shadow one ray decides:
    /// the ray to their centre; 1 = a ray per VAL (docs/LIGHTSKIN.md: the error this costs).
    int shadowCluster = 4;
};
/// Throws lightskin::Error naming the bad field.
void validate(const DifferentialSettings& settings);

/// A scene light as the differential sees it (gi::VirtualLight: intensity W/sr, spot cone uniform).
struct DifferentialLightSource {
    VirtualLight light;
    bool inRoom = true; ///< really in the room (in the camera image): only its shadow changes it
};

/// One receiver point (grid node (i, j) at pixel (i s + s/2, j s + s/2), s the receiver stride).
struct DifferentialReceiver {
    glm::dvec3 position{0.0};          ///< world metres
    glm::dvec3 normal{0.0};            ///< unit world, toward the camera
    float depth = 0.0f;                ///< camera z, metres
    bool valid = false;                ///< depth valid, window inside the image and continuous
    bool inRegion = false;             ///< valid and in the region the virtual objects can affect
    bool gathered = false;             ///< in the region and computed here (else interpolated in its cell)
    glm::dvec3 deltaIrradiance{0.0};   ///< dE, RGB W/m^2 (0 unless inRegion)
    glm::dvec3 irradianceWithout{0.0}; ///< E_without, RGB W/m^2 (0 unless inRegion)
};

struct DifferentialImages {
    cv::Mat deltaIrradiance;            ///< CV_32FC3 BGR dE per pixel, 0 where not affected
    cv::Mat irradianceWithout;          ///< CV_32FC3 BGR E_without per pixel, 0 where not affected
    cv::Mat affected;                   ///< CV_8UC1: 255 where the pixel interpolated receivers, else 0
    std::int64_t receiversInRegion = 0; ///< receivers in the region
    std::int64_t receiversGathered = 0; ///< of those, computed (the rest interpolated in their cells)
    std::int64_t shadowRays = 0;        ///< Embree rays cast (after the bounding-sphere tests)
};

class DifferentialIrradiance {
public:
    DifferentialIrradiance();
    ~DifferentialIrradiance();
    DifferentialIrradiance(DifferentialIrradiance&&) noexcept;
    DifferentialIrradiance& operator=(DifferentialIrradiance&&) noexcept;

    /// Builds the occluder scene (Embree) and the emitters from the placed virtual objects (their
    /// CPU meshes, world_T_model and diffuse albedo; the GPU views are not used). place() takes
    /// the same mesh objects. Throws lightskin::Error on bad settings, invalid meshes or Embree errors.
    static DifferentialIrradiance create(std::span<const MeshInstance> instances,
                                         const DifferentialSettings& settings = {});
    /// The same instances (meshes, in create()'s order) placed anew (world_T_model, diffuse albedo): occluders and
    /// emitters follow them, the ray scene is rebuilt in place. The meshes must still be those create() read.
    void place(std::span<const MeshInstance> instances);

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
    int receiverStride() const noexcept; ///< of the last compute(), pixels
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
