#pragma once
// Virtual area lights from a depth map (LightSkin section 5: "each captured pixel is an indirect
// area light"): one Lambertian disc VAL per valid depth pixel, or per s x s block, on the GPU (compute
// pass, atomic append: the output order is not deterministic, pixelIndexBuffer() names each VAL's depth
// pixel) with a double-precision CPU reference (PCL normals). Invalid pixels make no VAL at all, not a
// zero VAL: the gather's epsilon term would pull averaged light positions toward them.
// Units and frames: depth in metres (valid: minDepth < z <= maxDepth; 0, NaN, inf missing); VAL position
// and normal in the world frame (world_T_camera); area m^2; flux phi = pi L a, linear RGB. The sampling,
// normal, edge test, area and flux: docs/LIGHTSKIN.md, "VALs from depth".

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>
#include <lightskin/core/RgbdFrame.h>
#include <lightskin/gi/common/VirtualAreaLight.h>
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
    /// GL texture (R32F, width x height, texel row v = depth image row v from the top) holding the last
    /// generate()'s depth in metres (<= 0 or NaN = missing): the registered depth as
    /// gi::RealDepthView::texture wants it (owned by this generator; replaced by the next generate()).
    std::uint32_t depthTexture() const noexcept { return depthTexture_.id(); }
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

/// sRGB transfer function decoded to linear (IEC 61966-2-1), for one channel in [0, 1].
double srgbToLinear(double encoded) noexcept;

} // namespace lightskin::gi
