#include "Random.h"

#include <lightskin/core/Error.h>
#include <lightskin/synth/DepthNoise.h>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

namespace lightskin::synth {

namespace {
// Independent random streams per pixel (the third hash argument).
enum Stream : std::uint64_t { GrazingStream = 1, EdgeStream, LateralU, LateralV, AxialStream };

bool isJump(float a, float b, double relative) {
    if (a <= 0.0f || b <= 0.0f) return false;
    return std::abs(double(a) - double(b)) > relative * double(std::min(a, b));
}
} // namespace

double kinectAxialSigmaMetres(double z) noexcept { return 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4); }

double kinectLateralSigmaPixels(double theta) noexcept {
    const double clamped = std::min(theta, std::numbers::pi / 2.0 - 1e-3);
    return 0.8 + 0.035 * clamped / (std::numbers::pi / 2.0 - clamped);
}

double disparityStepMetres(const DepthNoiseDescription& noise, double z) noexcept {
    if (noise.disparitySubpixel <= 0.0) return 0.0;
    return z * z / (noise.sensorFocalPixels * std::abs(noise.baselineMetres) * noise.disparitySubpixel);
}

void applyDepthNoiseInto(const cv::Mat& exactDepth, const cv::Mat& cameraNormals, const CameraIntrinsics& intrinsics,
                         const DepthNoiseDescription& noise, std::int64_t frameIndex, cv::Mat& out) {
    cv::Mat scratch;
    applyDepthNoiseInto(exactDepth, cameraNormals, intrinsics, noise, frameIndex, out, scratch);
}

void applyDepthNoiseInto(const cv::Mat& exactDepth, const cv::Mat& cameraNormals, const CameraIntrinsics& intrinsics,
                         const DepthNoiseDescription& noise, std::int64_t frameIndex, cv::Mat& out, cv::Mat& scratch) {
    LIGHTSKIN_ASSERT(exactDepth.type() == CV_32FC1 && cameraNormals.type() == CV_32FC3 &&
                         exactDepth.size() == cameraNormals.size(),
                     "lightskin::synth::applyDepthNoiseInto(): expects CV_32FC1 depth and CV_32FC3 normals of one size");
    LIGHTSKIN_ASSERT(out.data != exactDepth.data, "lightskin::synth::applyDepthNoiseInto(): out must not alias the input");
    out.create(exactDepth.size(), CV_32FC1);
    if (!noise.enabled) {
        exactDepth.copyTo(out);
        return;
    }
    const int width = exactDepth.cols, height = exactDepth.rows;
    const auto frame = std::uint64_t(frameIndex);
    const auto pixelKey = [&](int u, int v) { return (frame << 32) ^ std::uint64_t(v * width + u); };
    const double degrees = std::numbers::pi / 180.0;
    // Lateral sigma in output pixels: the sensor's pixels scaled by the output's focal length.
    const double lateralScale = std::abs(intrinsics.fx) / noise.sensorFocalPixels;

    // 1. Projector shadow, per row (see the header). Out-of-range surfaces still cast shadows.
    scratch.create(height, width, CV_8UC1);
    scratch.setTo(0);
    cv::Mat_<std::uint8_t> dropped(scratch); // shares the pixels
    if (noise.projectorShadow && noise.baselineMetres != 0.0) {
        const double fb = intrinsics.fx * noise.baselineMetres;
        constexpr double tolerancePixels = 1e-3;
        for (int v = 0; v < height; ++v) {
            const float* z = exactDepth.ptr<float>(v);
            if (noise.baselineMetres > 0.0) {
                double smallest = std::numeric_limits<double>::infinity();
                for (int u = width - 1; u >= 0; --u) {
                    if (z[u] <= 0.0f) continue;
                    const double projectorColumn = u - fb / double(z[u]);
                    if (projectorColumn > smallest + tolerancePixels) dropped(v, u) = 1;
                    smallest = std::min(smallest, projectorColumn);
                }
            } else {
                double largest = -std::numeric_limits<double>::infinity();
                for (int u = 0; u < width; ++u) {
                    if (z[u] <= 0.0f) continue;
                    const double projectorColumn = u - fb / double(z[u]);
                    if (projectorColumn < largest - tolerancePixels) dropped(v, u) = 1;
                    largest = std::max(largest, projectorColumn);
                }
            }
        }
    }

    for (int v = 0; v < height; ++v) {
        const float* z = exactDepth.ptr<float>(v);
        const cv::Vec3f* normal = cameraNormals.ptr<cv::Vec3f>(v);
        float* result = out.ptr<float>(v);
        for (int u = 0; u < width; ++u) {
            result[u] = 0.0f;
            if (z[u] <= 0.0f || dropped(v, u)) continue;
            const std::uint64_t key = pixelKey(u, v);

            // 2. Grazing angle between the normal and the ray to the camera.
            const glm::dvec3 ray = glm::normalize(intrinsics.backProject(u, v, 1.0));
            const double cosTheta = std::abs(-(ray.x * double(normal[u][0]) + ray.y * double(normal[u][1]) + ray.z * double(normal[u][2])));
            const double theta = std::acos(std::clamp(cosTheta, 0.0, 1.0));
            const double grazingSpan = (noise.grazingEndDegrees - noise.grazingStartDegrees) * degrees;
            const double dropProbability = grazingSpan > 0.0
                ? std::clamp((theta - noise.grazingStartDegrees * degrees) / grazingSpan, 0.0, 1.0)
                : (theta >= noise.grazingEndDegrees * degrees ? 1.0 : 0.0);
            if (dropProbability > 0.0 && uniform01(noise.seed, key, GrazingStream, 0) < dropProbability) continue;

            // 3. Holes next to depth jumps.
            const bool nearJump = (u > 0 && isJump(z[u], z[u - 1], noise.edgeJumpRelative)) ||
                                  (u + 1 < width && isJump(z[u], z[u + 1], noise.edgeJumpRelative)) ||
                                  (v > 0 && isJump(z[u], exactDepth.at<float>(v - 1, u), noise.edgeJumpRelative)) ||
                                  (v + 1 < height && isJump(z[u], exactDepth.at<float>(v + 1, u), noise.edgeJumpRelative));
            if (nearJump && uniform01(noise.seed, key, EdgeStream, 0) < noise.edgeDropoutProbability) continue;

            // 4. Lateral noise: take the depth across a nearby jump.
            double depth = double(z[u]);
            if (noise.lateralNoise) {
                const double sigma = kinectLateralSigmaPixels(theta) * lateralScale;
                const int su = std::clamp(int(std::lround(u + sigma * standardNormal(noise.seed, key, LateralU, 0))), 0, width - 1);
                const int sv = std::clamp(int(std::lround(v + sigma * standardNormal(noise.seed, key, LateralV, 0))), 0, height - 1);
                const float sample = exactDepth.at<float>(sv, su);
                if ((su != u || sv != v) && (sample <= 0.0f || isJump(z[u], sample, noise.edgeJumpRelative))) {
                    if (sample <= 0.0f || dropped(sv, su)) continue;
                    depth = double(sample);
                }
            }

            // 5. Range.
            if (depth < noise.minRangeMetres || depth > noise.maxRangeMetres) continue;

            // 6. Axial noise, then disparity quantisation.
            if (noise.axialNoise) {
                const double sigma = kinectAxialSigmaMetres(depth);
                const double step = disparityStepMetres(noise, depth);
                const double sigmaAdded = std::sqrt(std::max(0.0, sigma * sigma - step * step / 12.0));
                depth += sigmaAdded * standardNormal(noise.seed, key, AxialStream, 0);
            }
            if (noise.disparitySubpixel > 0.0 && depth > 0.0) {
                const double fb = noise.sensorFocalPixels * std::abs(noise.baselineMetres);
                const double disparity = std::round(fb / depth * noise.disparitySubpixel) / noise.disparitySubpixel;
                depth = disparity > 0.0 ? fb / disparity : 0.0;
            }
            result[u] = depth > 0.0 ? float(depth) : 0.0f;
        }
    }
}

} // namespace lightskin::synth
