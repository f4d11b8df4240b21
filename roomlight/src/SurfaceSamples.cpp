#include "SurfaceSamples.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>

namespace lightskin::roomlight {
namespace {

// sRGB transfer function decoded (IEC 61966-2-1) for the 256 codes.
const std::array<double, 256>& srgbDecodeTable() {
    static const std::array<double, 256> table = [] {
        std::array<double, 256> values{};
        for (std::size_t code = 0; code < values.size(); ++code) {
            const double encoded = static_cast<double>(code) / 255.0;
            values[code] = encoded <= 0.04045 ? encoded / 12.92 : std::pow((encoded + 0.055) / 1.055, 2.4);
        }
        return values;
    }();
    return table;
}

struct DepthView {
    const cv::Mat& depth;
    double scale;
    double minMetres, maxMetres;
    double at(int u, int v) const {
        const double z = depth.at<std::uint16_t>(v, u) * scale;
        return (z >= minMetres && z <= maxMetres) ? z : 0.0;
    }
};

constexpr int kBinsPerAxis = 16;

} // namespace

void SurfaceSamples::clear() noexcept {
    positionWorld.clear();
    normalWorld.clear();
    radiance.clear();
    clipped.clear();
    footprintSquareMetres.clear();
    segment.clear();
    pixelIndex.clear();
}

void SurfaceSamples::reserve(std::size_t count) {
    positionWorld.reserve(count);
    normalWorld.reserve(count);
    radiance.reserve(count);
    clipped.reserve(count);
    footprintSquareMetres.reserve(count);
    segment.reserve(count);
    pixelIndex.reserve(count);
}

void extractSurfaceSamples(const RgbdFrame& frame, const Pose& world_T_camera, const RoomLightOptions& options,
                           SurfaceSamples& out) {
    out.clear();
    if (!frame.hasDepth() || !frame.hasColour()) return;
    const CameraIntrinsics& k = frame.colourIntrinsics;
    out.imageWidth = k.width;
    const int stride = options.stride, radius = options.normalRadius;
    out.reserve(static_cast<std::size_t>((k.width / stride + 1) * (k.height / stride + 1)));
    const DepthView depth{frame.depth, frame.depthScaleMetres, options.minDepthMetres, options.maxDepthMetres};
    const auto& decode = srgbDecodeTable();
    const double pixelArea = static_cast<double>(stride * stride) / std::abs(k.fx * k.fy);
    for (int v = stride / 2 + radius; v < k.height - radius; v += stride) {
        for (int u = stride / 2 + radius; u < k.width - radius; u += stride) {
            const double z = depth.at(u, v);
            if (z <= 0.0) continue;
            const double zl = depth.at(u - radius, v), zr = depth.at(u + radius, v);
            const double zu = depth.at(u, v - radius), zd = depth.at(u, v + radius);
            const double maxStep = options.maxDepthStepFraction * z;
            if (zl <= 0.0 || zr <= 0.0 || zu <= 0.0 || zd <= 0.0) continue;
            if (std::abs(zl - z) > maxStep || std::abs(zr - z) > maxStep || std::abs(zu - z) > maxStep ||
                std::abs(zd - z) > maxStep)
                continue;
            const glm::dvec3 point = k.backProject(u, v, z);
            const glm::dvec3 alongU = k.backProject(u + radius, v, zr) - k.backProject(u - radius, v, zl);
            const glm::dvec3 alongV = k.backProject(u, v + radius, zd) - k.backProject(u, v - radius, zu);
            glm::dvec3 normal = glm::cross(alongU, alongV);
            const double length = glm::length(normal);
            if (!(length > 0.0)) continue;
            normal /= length;
            if (glm::dot(normal, point) > 0.0) normal = -normal; // face the camera
            const double cosView = std::abs(glm::dot(normal, point)) / glm::length(point);
            const cv::Vec3b bgr = frame.colour.at<cv::Vec3b>(v, u);
            out.positionWorld.push_back(world_T_camera.transformPoint(point));
            out.normalWorld.push_back(glm::normalize(world_T_camera.transformDirection(normal)));
            out.radiance.push_back({decode[bgr[2]], decode[bgr[1]], decode[bgr[0]]});
            const int brightest = std::max({bgr[0], bgr[1], bgr[2]});
            out.clipped.push_back(brightest >= options.clippedCode ? 1 : 0);
            out.footprintSquareMetres.push_back(z * z * pixelArea / std::max(cosView, 0.2));
            out.segment.push_back(-1);
            out.pixelIndex.push_back(v * k.width + u);
        }
    }
}

int segmentSamples(SurfaceSamples& samples, std::vector<int>& binCounts) {
    binCounts.assign(kBinsPerAxis * kBinsPerAxis, 0);
    const auto binOf = [](const glm::dvec3& rgb) {
        const double sum = rgb.x + rgb.y + rgb.z;
        const int r = std::min(static_cast<int>(rgb.x / sum * kBinsPerAxis), kBinsPerAxis - 1);
        const int g = std::min(static_cast<int>(rgb.y / sum * kBinsPerAxis), kBinsPerAxis - 1);
        return r * kBinsPerAxis + g;
    };
    // Below ~1 % of full scale an 8-bit sRGB code step changes the chromaticity by more than a bin.
    constexpr double kMinSumForChromaticity = 0.03;
    int usable = 0;
    for (std::size_t i = 0; i < samples.size(); ++i) {
        samples.segment[i] = -1;
        const glm::dvec3& rgb = samples.radiance[i];
        if (samples.clipped[i] != 0 || rgb.x + rgb.y + rgb.z < kMinSumForChromaticity) continue;
        ++binCounts[static_cast<std::size_t>(binOf(rgb))];
        ++usable;
    }
    // binCounts is reused: after a bin is taken it holds -(segment + 1).
    int segments = 0;
    for (; segments < kMaxSegments; ++segments) {
        const auto largest = std::max_element(binCounts.begin(), binCounts.end());
        if (*largest <= 0) break;
        const int centre = static_cast<int>(largest - binCounts.begin());
        const int cr = centre / kBinsPerAxis, cg = centre % kBinsPerAxis;
        int members = 0;
        for (int r = std::max(cr - 1, 0); r <= std::min(cr + 1, kBinsPerAxis - 1); ++r) {
            for (int g = std::max(cg - 1, 0); g <= std::min(cg + 1, kBinsPerAxis - 1); ++g) {
                int& count = binCounts[static_cast<std::size_t>(r * kBinsPerAxis + g)];
                if (count < 0) continue;
                members += count;
                count = -(segments + 1);
            }
        }
        if (members * 100 < usable * 3) {
            break; // the rest are too small to fix an albedo: left out of the fit
        }
    }
    for (std::size_t i = 0; i < samples.size(); ++i) {
        const glm::dvec3& rgb = samples.radiance[i];
        if (samples.clipped[i] != 0 || rgb.x + rgb.y + rgb.z < kMinSumForChromaticity) continue;
        const int code = binCounts[static_cast<std::size_t>(binOf(rgb))];
        if (code < 0 && -code - 1 < segments) samples.segment[i] = -code - 1;
    }
    return segments;
}

} // namespace lightskin::roomlight
