// CpuValGenerator: val_from_depth.comp on the CPU (see the header). The function below follows the
// shader line by line; keep the two in step (gi_cpu_val_generator_gl_test compares them).
#include "TsanParallelRegion.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/common/CpuValGenerator.h>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec4.hpp>
#include <opencv2/core.hpp>

#include <cmath>
#include <string>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace lightskin::gi {

namespace {

constexpr float kPi = 3.14159265358979f;

struct PassInputs {
    const float* depth = nullptr;
    std::size_t depthStep = 0; // floats per row
    const cv::Mat* colour = nullptr;
    glm::ivec2 depthSize{0};
    int stride = 1, windowRadius = 1;
    glm::vec4 intrinsics{0.0f}; // fx, fy, cx, cy
    glm::mat4 world_T_camera{1.0f};
    float exposure = 1.0f, maxDepthChange = 0.0f, minCosine = 0.0f, minDepth = 0.0f, maxDepth = 0.0f;
    const float* srgbToLinear = nullptr;
};

/// One VAL-map pixel: false where the shader returns without appending.
bool valFromDepth(const PassInputs& in, glm::ivec2 valPixel, VirtualAreaLight& val, std::uint32_t& pixelIndex) {
    const auto depthAt = [&](glm::ivec2 p) { return in.depth[std::size_t(p.y) * in.depthStep + std::size_t(p.x)]; };
    // written so that NaN fails (every comparison with NaN is false)
    const auto validDepth = [&](float z) { return z > in.minDepth && z <= in.maxDepth; };
    const auto backProject = [&](glm::vec2 p, float z) {
        return glm::vec3((p.x - in.intrinsics.z) * z / in.intrinsics.x, (p.y - in.intrinsics.w) * z / in.intrinsics.y,
                         z);
    };
    const int R = in.windowRadius;
    const int s = in.stride;
    const glm::ivec2 c = valPixel * s + glm::ivec2(s / 2);
    if (c.x - R < 0 || c.y - R < 0 || c.x + R >= in.depthSize.x || c.y + R >= in.depthSize.y) return false;

    const float zc = depthAt(c);
    if (!validDepth(zc)) return false;
    const float maxStep = in.maxDepthChange * zc;

    // edge test: the centre cross
    const glm::ivec2 arms[4] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
    for (const glm::ivec2 arm : arms) {
        float previous = zc;
        for (int k = 1; k <= R; ++k) {
            const float z = depthAt(c + arm * k);
            if (!validDepth(z) || std::abs(z - previous) > maxStep) return false;
            previous = z;
        }
    }
    // border walk + 3D gradient sums
    glm::vec3 gx(0.0f), gy(0.0f);
    float prevL = depthAt(c + glm::ivec2(-R, -R)), prevR = depthAt(c + glm::ivec2(R, -R));
    float prevT = depthAt(c + glm::ivec2(-R, -R)), prevB = depthAt(c + glm::ivec2(-R, R));
    for (int d = -R; d <= R; ++d) {
        const glm::ivec2 pl = c + glm::ivec2(-R, d), pr = c + glm::ivec2(R, d), pt = c + glm::ivec2(d, -R),
                         pb = c + glm::ivec2(d, R);
        const float zl = depthAt(pl), zr = depthAt(pr), zt = depthAt(pt), zb = depthAt(pb);
        if (!validDepth(zl) || !validDepth(zr) || !validDepth(zt) || !validDepth(zb)) return false;
        if (std::abs(zl - prevL) > maxStep || std::abs(zr - prevR) > maxStep || std::abs(zt - prevT) > maxStep ||
            std::abs(zb - prevB) > maxStep)
            return false;
        prevL = zl;
        prevR = zr;
        prevT = zt;
        prevB = zb;
        gx += backProject(glm::vec2(pr), zr) - backProject(glm::vec2(pl), zl);
        gy += backProject(glm::vec2(pb), zb) - backProject(glm::vec2(pt), zt);
    }
    glm::vec3 n = glm::cross(gy, gx);
    const float nLength = glm::length(n);
    if (!(nLength > 0.0f) || std::isinf(nLength)) return false;
    n /= nLength;
    // position at the block centre; even s: mean of the central 2x2 depths
    float zBlock = zc;
    if (s % 2 == 0) {
        const float z00 = depthAt(c + glm::ivec2(-1, -1)), z10 = depthAt(c + glm::ivec2(0, -1)),
                    z01 = depthAt(c + glm::ivec2(-1, 0));
        if (!validDepth(z00) || !validDepth(z10) || !validDepth(z01) || std::abs(z00 - zc) > 2.0f * maxStep ||
            std::abs(z10 - zc) > maxStep || std::abs(z01 - zc) > maxStep)
            return false;
        zBlock = 0.25f * (z00 + z10 + z01 + zc);
    }
    const glm::vec3 p = backProject(glm::vec2(valPixel * s) + 0.5f * float(s - 1), zBlock);
    const glm::vec3 ray = glm::normalize(p);
    if (glm::dot(n, ray) > 0.0f) n = -n; // orient toward the camera

    const float footprint = (float(s) * zBlock / in.intrinsics.x) * (float(s) * zBlock / std::abs(in.intrinsics.y));
    const float cosAlpha = ray.z;
    const float cosTheta = std::max(-glm::dot(n, ray), in.minCosine);
    const float area = footprint * cosAlpha / cosTheta;

    // mean linear colour of the s x s block (BGR bytes)
    const glm::ivec2 blockStart = valPixel * s;
    glm::vec3 colour(0.0f);
    for (int y = 0; y < s; ++y) {
        const std::uint8_t* row = in.colour->ptr<std::uint8_t>(blockStart.y + y) + 3 * blockStart.x;
        for (int x = 0; x < s; ++x)
            colour += glm::vec3(in.srgbToLinear[row[3 * x + 2]], in.srgbToLinear[row[3 * x + 1]],
                                in.srgbToLinear[row[3 * x]]);
    }
    colour /= float(s * s);

    val.position = glm::vec3(in.world_T_camera * glm::vec4(p, 1.0f));
    val.area = area;
    val.normal = glm::normalize(glm::mat3(in.world_T_camera) * n);
    val.reserved0 = 0.0f;
    val.flux = kPi * in.exposure * colour * area;
    val.reserved1 = 0.0f;
    pixelIndex = std::uint32_t(c.y * in.depthSize.x + c.x);
    return true;
}

} // namespace

struct CpuValGenerator::Workers {
    tbb::task_arena arena;
};

CpuValGenerator::CpuValGenerator() = default;
CpuValGenerator::~CpuValGenerator() = default;
CpuValGenerator::CpuValGenerator(CpuValGenerator&&) noexcept = default;
CpuValGenerator& CpuValGenerator::operator=(CpuValGenerator&&) noexcept = default;

CpuValGenerator CpuValGenerator::create(int depthWidth, int depthHeight, const ValGeneratorSettings& settings,
                                        int threads) {
    validate(settings);
    if (depthWidth < 1 || depthHeight < 1 || depthWidth > 16384 || depthHeight > 16384)
        throw Error("CpuValGenerator", std::nullopt,
                    "depth map size " + std::to_string(depthWidth) + "x" + std::to_string(depthHeight) +
                        " out of range");
    if (threads < 0)
        throw Error("CpuValGenerator", std::nullopt,
                    "threads must be >= 0 (0 = all hardware threads), got " + std::to_string(threads));
    CpuValGenerator g;
    g.settings_ = settings;
    g.width_ = depthWidth;
    g.height_ = depthHeight;
    g.workers_ = std::make_unique<Workers>();
    g.workers_->arena.initialize(threads > 0 ? threads : int(tbb::task_arena::automatic));
    const std::size_t cells =
        std::size_t(valMapWidth(depthWidth, settings)) * std::size_t(valMapHeight(depthHeight, settings));
    g.slots_.resize(cells);
    g.vals_.resize(cells);
    g.valid_.resize(cells);
    g.pixelIndices_.resize(cells);
    for (int i = 0; i < 256; ++i) g.srgbToLinear_[std::size_t(i)] = float(srgbToLinear(double(i) / 255.0));
    g.depthMetres_.create(depthHeight, depthWidth, CV_32FC1);
    return g;
}

void CpuValGenerator::setSettings(const ValGeneratorSettings& settings) {
    validate(settings);
    if (settings.stride != settings_.stride || settings.normalWindowRadius != settings_.normalWindowRadius)
        throw Error("CpuValGenerator", std::nullopt, "stride and normalWindowRadius are fixed at create()");
    settings_ = settings;
}

std::span<const VirtualAreaLight> CpuValGenerator::generate(const cv::Mat& depth, double depthScaleMetres,
                                                            const cv::Mat& colourBgr, const CameraIntrinsics& K,
                                                            const Pose& world_T_camera) {
    LIGHTSKIN_ASSERT(width_ > 0, "lightskin::gi::CpuValGenerator::generate(): used before create()");
    if (depth.cols != width_ || depth.rows != height_ || (depth.type() != CV_16UC1 && depth.type() != CV_32FC1))
        throw Error("CpuValGenerator", std::nullopt,
                    "depth must be CV_16UC1 or CV_32FC1 of " + std::to_string(width_) + "x" + std::to_string(height_));
    if (colourBgr.size() != depth.size() || colourBgr.type() != CV_8UC3)
        throw Error("CpuValGenerator", std::nullopt, "colour must be CV_8UC3 (BGR) of the depth map's size");
    if (!(K.fx != 0.0 && K.fy != 0.0 && std::isfinite(K.fx) && std::isfinite(K.fy) && std::isfinite(K.cx) &&
          std::isfinite(K.cy)))
        throw Error("CpuValGenerator", std::nullopt, "invalid intrinsics: " + K.describe());
    const cv::Mat* depthMetres = &depth;
    if (depth.type() == CV_16UC1) {
        depth.convertTo(depthMetres_, CV_32FC1, depthScaleMetres); // sized at create(): no allocation
        depthMetres = &depthMetres_;
    }
    PassInputs in;
    in.depth = depthMetres->ptr<float>(0);
    in.depthStep = depthMetres->step1();
    in.colour = &colourBgr;
    in.depthSize = {width_, height_};
    in.stride = settings_.stride;
    in.windowRadius = settings_.normalWindowRadius;
    in.intrinsics = glm::vec4(float(K.fx), float(K.fy), float(K.cx), float(K.cy));
    in.world_T_camera = world_T_camera.matrixFloat();
    in.exposure = settings_.exposure;
    in.maxDepthChange = settings_.maxDepthChange;
    in.minCosine = settings_.minCosine;
    in.minDepth = settings_.minDepth;
    in.maxDepth = settings_.maxDepth;
    in.srgbToLinear = srgbToLinear_.data();

    const int mapW = valMapWidth(width_, settings_), mapH = valMapHeight(height_, settings_);
    // Rows of the VAL map are independent; each cell has its own slot, packed in raster order below.
    {
        // the task body reads its inputs through this context (TsanParallelRegion.h); joined at the
        // end of this scope
        struct Context {
            const PassInputs& in;
            int mapW;
            std::uint8_t* valid;
            VirtualAreaLight* slots;
            std::uint32_t* pixelIndices;
            detail::TsanParallelRegion region;
        } context{in, mapW, valid_.data(), slots_.data(), pixelIndices_.data(), {}};
        workers_->arena.execute([&] {
            // static_partitioner (rows cost about the same): auto_partitioner's work-stealing flags
            // are atomics that libtbb initialises and hands over unseen by TSan, whose reports then
            // have no restorable stack to suppress them by (TsanParallelRegion.h)
            tbb::parallel_for(
                tbb::blocked_range<int>(0, mapH, 4),
                [ctx = &context](const tbb::blocked_range<int>& rows) {
                    const Context& c = *detail::TsanParallelRegion::captured(ctx);
                    c.region.taskBegin();
                    for (int j = rows.begin(); j < rows.end(); ++j)
                        for (int i = 0; i < c.mapW; ++i) {
                            const std::size_t cell = std::size_t(j) * std::size_t(c.mapW) + std::size_t(i);
                            c.valid[cell] = valFromDepth(c.in, {i, j}, c.slots[cell], c.pixelIndices[cell]) ? 1 : 0;
                        }
                    c.region.taskEnd();
                },
                tbb::static_partitioner());
        });
    }
    std::size_t n = 0;
    for (std::size_t cell = 0; cell < slots_.size(); ++cell)
        if (valid_[cell]) {
            vals_[n] = slots_[cell];
            pixelIndices_[n] = pixelIndices_[cell]; // n <= cell: this cell's index is read before being overwritten
            ++n;
        }
    count_ = n;
    return lastVals();
}

} // namespace lightskin::gi
