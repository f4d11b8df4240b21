#pragma once
// Virtual area lights from a depth map (LightSkin section 5: "each captured pixel is an indirect
// area light"). Every valid pixel of the (filtered) depth map, or every s-th pixel in each
// direction, becomes one Lambertian disc VAL. GPU implementation (compute pass, packed output with
// an atomic counter) plus a double-precision CPU reference whose normals come from PCL's
// IntegralImageNormalEstimation.
//
// Per-pixel definition (GPU; the reference differs only in the normal and its validity):
//  * Sampling: VAL-map pixel (i, j), map size floor(W/s) x floor(H/s), samples depth pixel
//    c = (i*s + s/2, j*s + s/2) and stands for the s x s block starting at (i*s, j*s).
//  * Valid depth: minDepth < z <= maxDepth (metres); 0, negative, NaN and +-inf are missing.
//  * Normal: PCL's AVERAGE_3D_GRADIENT over the (2R+1)^2 window around c, telescoped to the window
//    sides: g_x = sum_d P(c+(R,d)) - P(c+(-R,d)), g_y = sum_d P(c+(d,R)) - P(c+(d,-R)),
//    n = normalize(g_y x g_x), flipped to face the camera. P = back-projection (camera frame).
//  * Edge test (no VAL at depth edges): the window must lie inside the image, and every sample on
//    the centre cross (c to c +- R along x and y) and on the window border must be valid and differ
//    from the previous sample of its walk by at most maxDepthChange * z(c). Adjacent pixels of a
//    real surface tilted by theta differ by about z * tan(theta) / f, so the default 0.03 (with
//    f = 525 px) keeps surfaces up to ~86 degrees and cuts jumps of > 3 cm at 1 m.
//    A VAL is also dropped when |g_y x g_x| is 0 or not finite.
//  * Area: the exact differential area of the surface seen through the s x s block,
//        a = (s z / fx) (s z / |fy|) * cos(alpha) / max(cos(theta), minCosine),
//    alpha = angle between the view ray and the optical axis, theta = angle between the normal and
//    the view ray. (The footprint divided by cos(theta) alone overestimates an off-axis pixel by
//    1/cos(alpha): +22 % in a Kinect image corner; a fronto-parallel plane then sums to more than
//    its area.) Clamp: where cos(theta) < minCosine (default 0.2, i.e. theta > 78.5 degrees) the
//    area is underestimated by cos(theta)/minCosine instead of growing without bound as noisy
//    normals approach grazing; a <= footprint * cos(alpha) / minCosine.
//  * Flux: Lambertian emitter, phi = pi * L * a with radiance L = exposure * mean linear RGB of the
//    block (sRGB decoded per pixel with the exact IEC 61966-2-1 curve, then averaged).
//  * Position: world_T_camera * P at the block centre (i*s + (s-1)/2, j*s + (s-1)/2) with depth
//    z(c) for odd s, the mean of the central 2x2 depths for even s (these must be valid and
//    continuous too); area uses that depth. Normal: rotation of world_T_camera applied to n.
// Invalid pixels produce no VAL at all (not a zero VAL): the gather's epsilon term would otherwise
// pull averaged light positions toward them. The GPU output order is not deterministic (atomic
// append); pixelIndexBuffer() says which depth pixel each VAL came from.

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>
#include <lightskin/core/RgbdFrame.h>
#include <lightskin/gi/VirtualAreaLight.h>
#include <lightskin/gl/GpuTimer.h>
#include <lightskin/gl/Objects.h>

#include <glm/vec3.hpp>
#include <opencv2/core/mat.hpp>

#include <cstdint>
#include <vector>

namespace lightskin::gi {

struct ValGeneratorSettings {
    /// s >= 1: one VAL per s x s block of depth pixels. Fixed when the generator is created.
    int stride = 1;
    /// Radiance scale: L = exposure * linear RGB (a scene setting: how bright "white" is).
    float exposure = 1.0f;
    /// R >= 1: half size of the normal window in full-resolution depth pixels (PCL smoothing 2R).
    /// Fixed when the generator is created (it sizes the shared-memory tile).
    int normalWindowRadius = 5;
    /// Relative depth step between adjacent samples that counts as an edge (see above).
    float maxDepthChange = 0.03f;
    /// Lower clamp of cos(normal, view ray) in the area, in (0, 1].
    float minCosine = 0.2f;
    /// Valid depth range, metres: minDepth < z <= maxDepth.
    float minDepth = 0.0f;
    float maxDepth = 1.0e6f;
    /// CPU reference only: PCL IntegralImageNormalEstimation's max depth change factor (PCL default
    /// semantics: adjacent pixels differing by > factor * 2 (z + 1) are a depth change).
    float pclMaxDepthChangeFactor = 0.02f;
    /// Static content: when depth (after unit conversion), colour, intrinsics, pose and settings
    /// are bit-identical to the previous generate(), skip upload and pass and return the same set
    /// with the same ValSetView::generation (a consumer may then reuse its results). Costs one
    /// compare (and, when changed, one copy) of depth and colour on the CPU, ~2 MB at 640x480.
    /// Off by default: benchmarks that repeat one frame must time the pass.
    bool skipUnchangedInput = false;
};

/// Checks the settings; throws lightskin::Error naming the bad field.
void validate(const ValGeneratorSettings& settings);

/// VAL-map size for a depth map of width x height.
inline int valMapWidth(int depthWidth, const ValGeneratorSettings& s) { return depthWidth / s.stride; }
inline int valMapHeight(int depthHeight, const ValGeneratorSettings& s) { return depthHeight / s.stride; }

/// GPU VAL generation. Owns its GL objects (needs a current GL 4.5 context from create() to
/// destruction). Buffers are sized once for one depth-map size; generate() does not allocate.
class ValGenerator {
public:
    ValGenerator() = default;
    /// Compiles the pass and sizes textures and buffers for depth maps of depthWidth x depthHeight.
    /// Throws lightskin::Error on bad settings or sizes.
    static ValGenerator create(int depthWidth, int depthHeight, const ValGeneratorSettings& settings = {});

    /// Uploads depth and colour and runs the pass. `depth`: CV_16UC1 (raw units, metres = value *
    /// depthScaleMetres, 0 = missing) or CV_32FC1 (metres, NaN/0 = missing); `colourBgr`: CV_8UC3,
    /// BGR, sRGB-encoded, same size as depth (registered to depth). Reads the count back (a GPU sync).
    /// Throws lightskin::Error on wrong types or sizes. GL state left changed: current program,
    /// texture units 0-1, SSBO bindings 0-2 (everything else as found).
    ValSetView generate(const cv::Mat& depth, double depthScaleMetres, const cv::Mat& colourBgr,
                        const CameraIntrinsics& depthIntrinsics, const Pose& world_T_camera);
    /// The same for a registered RgbdFrame (its depth intrinsics and scale).
    ValSetView generate(const RgbdFrame& frame, const Pose& world_T_camera);

    /// Exposure etc. may change per frame; stride and normalWindowRadius may not (buffers, tile).
    void setSettings(const ValGeneratorSettings& settings);
    const ValGeneratorSettings& settings() const noexcept { return settings_; }

    /// When set (not owned; may be null), generate() brackets its stages "val upload" and
    /// "val pass" with begin()/end() on this timer; the caller runs beginFrame()/collect().
    void setStageTimer(gl::GpuStageTimer* timer) noexcept { timer_ = timer; }

    /// The last generate()'s set (buffer owned by this generator). generation counts the passes
    /// run (1, 2, ...; kept when skipUnchangedInput skipped one); keys = pixelIndexBuffer(), key
    /// space width * height, keyWidth = width (the depth image's quadtree).
    ValSetView lastSet() const noexcept {
        return {vals_.id(), lastCount_, generation_, pixelIndices_.id(),
                std::uint32_t(width_) * std::uint32_t(height_), std::uint32_t(width_)};
    }
    /// Whether the last generate() skipped the pass (skipUnchangedInput and identical input).
    bool lastSkipped() const noexcept { return lastSkipped_; }
    /// GL buffer: uint per VAL, the depth pixel index (v * width + u) it came from.
    std::uint32_t pixelIndexBuffer() const noexcept { return pixelIndices_.id(); }
    /// GL buffer holding the count (one uint), for consumers that avoid the read-back.
    std::uint32_t countBuffer() const noexcept { return counter_.id(); }
    std::uint32_t capacity() const noexcept { return capacity_; }

    /// Copies the last set back (tests, debugging; allocates).
    std::vector<VirtualAreaLight> downloadVals() const;
    std::vector<std::uint32_t> downloadPixelIndices() const;

private:
    void reservePreviousInput();

    ValGeneratorSettings settings_;
    int width_ = 0, height_ = 0;
    std::uint32_t capacity_ = 0, lastCount_ = 0;
    std::uint64_t generation_ = 0;
    bool lastSkipped_ = false;
    // skipUnchangedInput: the inputs of the last pass (sized at create())
    cv::Mat previousDepth_, previousColour_;
    glm::dvec4 previousIntrinsics_{0.0};
    Pose previousPose_;
    bool previousValid_ = false;
    gl::Program program_;
    gl::Texture depthTexture_, colourTexture_;
    gl::Buffer vals_, pixelIndices_, counter_;
    cv::Mat depthMetres_; // CV_32FC1 staging for 16-bit input, sized once
    gl::GpuStageTimer* timer_ = nullptr;
};

/// One VAL of the CPU reference, double precision.
struct ReferenceVal {
    glm::dvec3 position{0.0};
    double area = 0.0;
    glm::dvec3 normal{0.0, 0.0, 1.0};
    glm::dvec3 flux{0.0};
    std::uint32_t pixelIndex = 0;
};

/// CPU reference in double precision: same sampling, validity of depth, area, flux and transform
/// as the GPU, but the normal (and its validity, incl. edges) is PCL's
/// IntegralImageNormalEstimation (AVERAGE_3D_GRADIENT, smoothing 2R, pclMaxDepthChangeFactor, no
/// depth-dependent smoothing, border ignored), oriented toward the camera. Output in raster order.
std::vector<ReferenceVal> generateValsReference(const cv::Mat& depth, double depthScaleMetres, const cv::Mat& colourBgr,
                                                const CameraIntrinsics& depthIntrinsics, const Pose& world_T_camera,
                                                const ValGeneratorSettings& settings);

/// sRGB transfer function decoded to linear (IEC 61966-2-1), for one channel in [0, 1].
double srgbToLinear(double encoded) noexcept;

} // namespace lightskin::gi
