#include <lightskin/core/Error.h>
#include <lightskin/render/Compositor.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

namespace lightskin::render {

float kinectAxialNoiseMetres(float z) noexcept { return 0.0012f + 0.0019f * (z - 0.4f) * (z - 0.4f); }

float visibility(float zVirtual, float zReal, const CompositeSettings& s) noexcept {
    if (!(zReal > 0.0f) || !std::isfinite(zReal)) return 1.0f;
    const float band = std::max(s.minSoftBandMetres, s.softBandSigmas * kinectAxialNoiseMetres(zVirtual));
    if (!(band > 0.0f)) return zReal >= zVirtual ? 1.0f : 0.0f;
    return std::clamp((zReal - zVirtual) / (2.0f * band) + 0.5f, 0.0f, 1.0f);
}

namespace {
/// The share a of a virtual pixel in the composite: its coverage alpha (8 bit) times its visibility over the
/// real depth (none without real depth). One function for compositeInto(), compositeLinearInto() and
/// visibleInto(), so that what the measures call visible is what the composite shows.
float compositeShare(std::uint8_t coverageAlpha, float zVirtual, const float* zRealRow, int u,
                     const CompositeSettings& settings) noexcept {
    if (coverageAlpha == 0) return 0.0f;
    return float(coverageAlpha) / 255.0f * (zRealRow != nullptr ? visibility(zVirtual, zRealRow[u], settings) : 1.0f);
}
} // namespace

Compositor Compositor::create(const CameraIntrinsics& k, const CompositeSettings& settings) {
    if (!k.isValid()) throw Error("compositor", std::nullopt, "invalid colour intrinsics " + k.describe());
    Compositor c;
    c.intrinsics_ = k;
    c.settings_ = settings;
    if (k.hasDistortion()) {
        // For every pixel of the distorted camera image, where it lies in the ideal pinhole render.
        std::vector<cv::Point2f> distorted;
        distorted.reserve(std::size_t(k.width) * std::size_t(k.height));
        for (int v = 0; v < k.height; ++v)
            for (int u = 0; u < k.width; ++u) distorted.emplace_back(float(u), float(v));
        const cv::Matx33d cameraMatrix(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
        std::vector<cv::Point2f> ideal;
        cv::undistortPoints(distorted, ideal, cameraMatrix, cv::Mat(1, 5, CV_64F, const_cast<double*>(k.distortion.data())),
                            cv::noArray(), cameraMatrix);
        c.mapX_.create(k.height, k.width, CV_32FC1);
        c.mapY_.create(k.height, k.width, CV_32FC1);
        for (int v = 0; v < k.height; ++v)
            for (int u = 0; u < k.width; ++u) {
                const cv::Point2f& p = ideal[std::size_t(v) * std::size_t(k.width) + std::size_t(u)];
                c.mapX_.at<float>(v, u) = p.x;
                c.mapY_.at<float>(v, u) = p.y;
            }
        // Each render pixel's index (exact in float below 2^24 pixels), warped like the layers by visibleInto().
        LIGHTSKIN_ASSERT(std::int64_t(k.width) * k.height < (std::int64_t(1) << 24),
                         "lightskin::render::Compositor::create(): image too large for the pixel index map");
        c.renderIndex_.create(k.height, k.width, CV_32FC1);
        for (int v = 0; v < k.height; ++v)
            for (int u = 0; u < k.width; ++u) c.renderIndex_.at<float>(v, u) = float(v * k.width + u);
    }
    return c;
}

void Compositor::compositeInto(const cv::Mat& camera, const cv::Mat& virtualRgba, const cv::Mat& virtualDepth,
                               const cv::Mat& realDepth, cv::Mat& out) {
    const cv::Size size(intrinsics_.width, intrinsics_.height);
    LIGHTSKIN_ASSERT(camera.type() == CV_8UC3 && camera.size() == size, "lightskin::render::Compositor::compositeInto(): camera image must be CV_8UC3 of the intrinsics' size");
    LIGHTSKIN_ASSERT(virtualRgba.type() == CV_8UC4 && virtualRgba.size() == size, "lightskin::render::Compositor::compositeInto(): virtual colour must be CV_8UC4");
    LIGHTSKIN_ASSERT(virtualDepth.type() == CV_32FC1 && virtualDepth.size() == size, "lightskin::render::Compositor::compositeInto(): virtual depth must be CV_32FC1");
    LIGHTSKIN_ASSERT(realDepth.empty() || (realDepth.type() == CV_32FC1 && realDepth.size() == size),
                     "lightskin::render::Compositor::compositeInto(): real depth must be empty or CV_32FC1 of the same size");
    const cv::Mat* colour = &virtualRgba;
    const cv::Mat* depth = &virtualDepth;
    if (!mapX_.empty()) {
        cv::remap(virtualRgba, warpedColour_, mapX_, mapY_, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar::all(0));
        cv::remap(virtualDepth, warpedDepth_, mapX_, mapY_, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar::all(0));
        colour = &warpedColour_;
        depth = &warpedDepth_;
    }
    camera.copyTo(out);
    for (int v = 0; v < size.height; ++v) {
        const auto* rgba = colour->ptr<cv::Vec4b>(v);
        const auto* zv = depth->ptr<float>(v);
        const float* zr = realDepth.empty() ? nullptr : realDepth.ptr<float>(v);
        auto* dst = out.ptr<cv::Vec3b>(v);
        for (int u = 0; u < size.width; ++u) {
            const float a = compositeShare(rgba[u][3], zv[u], zr, u, settings_);
            if (a <= 0.0f) continue;
            for (int c = 0; c < 3; ++c) {
                const float virtualValue = float(rgba[u][2 - c]); // RGBA -> BGR
                dst[u][c] = cv::saturate_cast<std::uint8_t>(float(dst[u][c]) * (1.0f - a) + virtualValue * a);
            }
        }
    }
}

namespace {
float srgbEncode(float linear) noexcept {
    return linear <= 0.0031308f ? 12.92f * linear : 1.055f * std::pow(linear, 1.0f / 2.4f) - 0.055f;
}
float srgbDecode(float encoded) noexcept {
    return encoded <= 0.04045f ? encoded / 12.92f : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
}

/// round(255 srgbEncode(linear)) for linear in [0, 1] without a pow per value: the code is the number of
/// rounding boundaries (the linear values of codes k + 0.5, in double) at or below it, searched from a
/// 4096-bin start (one bin spans under one code, so the search takes at most two steps).
class SrgbEncoder8 {
public:
    SrgbEncoder8() {
        for (std::size_t k = 0; k < boundary_.size(); ++k) {
            const double e = (double(k) + 0.5) / 255.0;
            boundary_[k] = float(e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4));
        }
        for (std::size_t b = 0; b < start_.size(); ++b) {
            const float x = float(b) / float(start_.size());
            start_[b] = std::uint8_t(std::upper_bound(boundary_.begin(), boundary_.end(), x) - boundary_.begin());
        }
    }
    std::uint8_t operator()(float linear) const noexcept {
        const float x = std::clamp(linear, 0.0f, 1.0f);
        std::size_t code = start_[std::min(std::size_t(x * float(start_.size())), start_.size() - 1)];
        while (code < boundary_.size() && x >= boundary_[code]) ++code;
        return std::uint8_t(code);
    }

private:
    std::array<float, 255> boundary_{};
    std::array<std::uint8_t, 4096> start_{};
};
} // namespace

void Compositor::compositeLinearInto(const cv::Mat& camera, const cv::Mat& virtualLinear, const cv::Mat& virtualRgba,
                                     const cv::Mat& virtualDepth, const cv::Mat& realDepth, cv::Mat& out) {
    const cv::Size size(intrinsics_.width, intrinsics_.height);
    LIGHTSKIN_ASSERT(camera.type() == CV_8UC3 && camera.size() == size, "lightskin::render::Compositor::compositeLinearInto(): camera image must be CV_8UC3 of the intrinsics' size");
    LIGHTSKIN_ASSERT(virtualLinear.type() == CV_32FC4 && virtualLinear.size() == size, "lightskin::render::Compositor::compositeLinearInto(): virtual linear colour must be CV_32FC4");
    LIGHTSKIN_ASSERT(virtualRgba.type() == CV_8UC4 && virtualRgba.size() == size, "lightskin::render::Compositor::compositeLinearInto(): virtual colour must be CV_8UC4");
    LIGHTSKIN_ASSERT(virtualDepth.type() == CV_32FC1 && virtualDepth.size() == size, "lightskin::render::Compositor::compositeLinearInto(): virtual depth must be CV_32FC1");
    LIGHTSKIN_ASSERT(realDepth.empty() || (realDepth.type() == CV_32FC1 && realDepth.size() == size),
                     "lightskin::render::Compositor::compositeLinearInto(): real depth must be empty or CV_32FC1 of the same size");
    static const std::array<float, 256> decoded = [] {
        std::array<float, 256> table{};
        for (std::size_t i = 0; i < table.size(); ++i) table[i] = srgbDecode(float(i) / 255.0f);
        return table;
    }();
    const cv::Mat* linear = &virtualLinear;
    const cv::Mat* colour = &virtualRgba;
    const cv::Mat* depth = &virtualDepth;
    if (!mapX_.empty()) {
        cv::remap(virtualLinear, warpedLinear_, mapX_, mapY_, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar::all(0));
        cv::remap(virtualRgba, warpedColour_, mapX_, mapY_, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar::all(0));
        cv::remap(virtualDepth, warpedDepth_, mapX_, mapY_, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar::all(0));
        linear = &warpedLinear_;
        colour = &warpedColour_;
        depth = &warpedDepth_;
    }
    // Where no virtual content is (alpha 0, most of a camera frame) the output is the decoded camera pixel: the
    // table over the whole image first (cv::LUT copies its float entries, vectorised), then the blend below only
    // where alpha > 0. The same values as decoding pixel by pixel.
    const cv::Mat decodedTable(1, 256, CV_32FC1, const_cast<float*>(decoded.data()));
    cv::LUT(camera, decodedTable, out);
    for (int v = 0; v < size.height; ++v) {
        const auto* cam = camera.ptr<cv::Vec3b>(v);
        const auto* lin = linear->ptr<cv::Vec4f>(v);
        const auto* rgba = colour->ptr<cv::Vec4b>(v);
        const auto* zv = depth->ptr<float>(v);
        const float* zr = realDepth.empty() ? nullptr : realDepth.ptr<float>(v);
        auto* dst = out.ptr<cv::Vec3f>(v);
        for (int u = 0; u < size.width; ++u) {
            if (rgba[u][3] == 0) continue; // the decoded camera pixel
            const float a = compositeShare(rgba[u][3], zv[u], zr, u, settings_);
            for (int c = 0; c < 3; ++c) {
                const float virtualValue = lin[u][2 - c]; // RGBA -> BGR
                if (a <= 0.0f) {
                    dst[u][c] = decoded[cam[u][c]];
                } else if (a >= 1.0f || !std::isfinite(virtualValue)) {
                    dst[u][c] = virtualValue;
                } else {
                    const float encoded = float(cam[u][c]) / 255.0f * (1.0f - a) + srgbEncode(std::clamp(virtualValue, 0.0f, 1.0f)) * a;
                    dst[u][c] = srgbDecode(encoded);
                }
            }
        }
    }
}

void Compositor::visibleInto(const cv::Mat& virtualRgba, const cv::Mat& virtualDepth, const cv::Mat& realDepth,
                             cv::Mat& visible) {
    const cv::Size size(intrinsics_.width, intrinsics_.height);
    LIGHTSKIN_ASSERT(virtualRgba.type() == CV_8UC4 && virtualRgba.size() == size,
                     "lightskin::render::Compositor::visibleInto(): virtual colour must be CV_8UC4");
    LIGHTSKIN_ASSERT(virtualDepth.type() == CV_32FC1 && virtualDepth.size() == size,
                     "lightskin::render::Compositor::visibleInto(): virtual depth must be CV_32FC1");
    LIGHTSKIN_ASSERT(
        realDepth.empty() || (realDepth.type() == CV_32FC1 && realDepth.size() == size),
        "lightskin::render::Compositor::visibleInto(): real depth must be empty or CV_32FC1 of the same size");
    visible.create(size, CV_8UC1);
    visible.setTo(cv::Scalar::all(0));
    if (mapX_.empty()) { // output pixel = render pixel
        for (int v = 0; v < size.height; ++v) {
            const auto* rgba = virtualRgba.ptr<cv::Vec4b>(v);
            const auto* zv = virtualDepth.ptr<float>(v);
            const float* zr = realDepth.empty() ? nullptr : realDepth.ptr<float>(v);
            auto* dst = visible.ptr<std::uint8_t>(v);
            for (int u = 0; u < size.width; ++u)
                if (compositeShare(rgba[u][3], zv[u], zr, u, settings_) > 0.0f) dst[u] = 255;
        }
        return;
    }
    // With distortion an output pixel shows the render pixel the warp takes it from: the same remaps as the
    // composite, plus the render pixels' indices warped alike, so each output pixel names its source.
    cv::remap(virtualRgba, warpedColour_, mapX_, mapY_, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar::all(0));
    cv::remap(virtualDepth, warpedDepth_, mapX_, mapY_, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar::all(0));
    cv::remap(renderIndex_, warpedIndex_, mapX_, mapY_, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar::all(-1));
    for (int v = 0; v < size.height; ++v) {
        const auto* rgba = warpedColour_.ptr<cv::Vec4b>(v);
        const auto* zv = warpedDepth_.ptr<float>(v);
        const auto* index = warpedIndex_.ptr<float>(v);
        const float* zr = realDepth.empty() ? nullptr : realDepth.ptr<float>(v);
        for (int u = 0; u < size.width; ++u) {
            if (!(compositeShare(rgba[u][3], zv[u], zr, u, settings_) > 0.0f) || index[u] < 0.0f) continue;
            const int i = int(index[u]);
            visible.at<std::uint8_t>(i / size.width, i % size.width) = 255;
        }
    }
}

void applyDifferentialInto(const cv::Mat& camera, const gi::DifferentialImages& d, float exposureStops, cv::Mat& out) {
    LIGHTSKIN_ASSERT(camera.type() == CV_8UC3,
                     "lightskin::render::applyDifferentialInto(): camera image must be CV_8UC3");
    LIGHTSKIN_ASSERT(d.deltaIrradiance.type() == CV_32FC3 && d.deltaIrradiance.size() == camera.size() &&
                         d.irradianceWithout.type() == CV_32FC3 && d.irradianceWithout.size() == camera.size() &&
                         d.affected.type() == CV_8UC1 && d.affected.size() == camera.size(),
                     "lightskin::render::applyDifferentialInto(): differential images must be CV_32FC3/CV_8UC1 of the "
                     "camera's size");
    LIGHTSKIN_ASSERT(out.data != camera.data,
                     "lightskin::render::applyDifferentialInto(): out must not alias the camera image");
    static const std::array<float, 256> decoded = [] {
        std::array<float, 256> table{};
        for (std::size_t i = 0; i < table.size(); ++i) table[i] = srgbDecode(float(i) / 255.0f);
        return table;
    }();
    static const SrgbEncoder8 encode;
    const float gain = std::exp2(exposureStops), pi = 3.14159265358979f;
    out.create(camera.size(), camera.type());
    cv::parallel_for_(cv::Range(0, camera.rows), [&](const cv::Range& rows) {
        for (int v = rows.start; v < rows.end; ++v) {
            const auto* affected = d.affected.ptr<std::uint8_t>(v);
            const auto* delta = d.deltaIrradiance.ptr<cv::Vec3f>(v);
            const auto* without = d.irradianceWithout.ptr<cv::Vec3f>(v);
            const auto* src = camera.ptr<cv::Vec3b>(v);
            auto* dst = out.ptr<cv::Vec3b>(v);
            std::copy(src, src + camera.cols, dst);
            for (int u = 0; u < camera.cols; ++u) {
                if (affected[u] == 0) continue;
                for (int c = 0; c < 3; ++c) {
                    const float dE = delta[u][c], eWithout = without[u][c];
                    if (dE == 0.0f || !(eWithout > 0.0f) || !std::isfinite(dE) || !std::isfinite(eWithout)) continue;
                    // rho / pi = min(p / (gain E_without), 1 / pi): p >= 0 and E_without > 0 here.
                    const float p = decoded[dst[u][c]];
                    const float albedoOverPi = std::min(p / (gain * eWithout), 1.0f / pi);
                    dst[u][c] = encode(p + gain * albedoOverPi * dE);
                }
            }
        }
    });
}

void sideBySideInto(const cv::Mat& left, const std::string& leftCaption, const cv::Mat& right, const std::string& rightCaption,
                    cv::Mat& out) {
    LIGHTSKIN_ASSERT(left.type() == CV_8UC3 && right.type() == left.type() && left.size() == right.size(),
                     "lightskin::render::sideBySideInto(): images must be equally sized CV_8UC3");
    cv::hconcat(left, right, out);
    const double scale = std::max(0.4, double(left.rows) / 600.0);
    const auto caption = [&](const std::string& text, int x) {
        const cv::Point origin(x + 8, int(24.0 * scale) + 4);
        cv::putText(out, text, origin, cv::FONT_HERSHEY_SIMPLEX, 0.7 * scale, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
        cv::putText(out, text, origin, cv::FONT_HERSHEY_SIMPLEX, 0.7 * scale, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
    };
    caption(leftCaption, 0);
    caption(rightCaption, left.cols);
}

} // namespace lightskin::render
