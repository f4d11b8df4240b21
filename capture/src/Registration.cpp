#include <lightskin/capture/Registration.h>
#include <lightskin/core/Error.h>

#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>
#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace lightskin::capture {

Pose kinectV1DefaultColour_T_depth() {
    return Pose(glm::dquat(1.0, 0.0, 0.0, 0.0), glm::dvec3(0.0250319, 0.00066239, -0.00029342));
}

CameraIntrinsics kinectV1DefaultDepthIntrinsics() { return {640, 480, 575.8157, 575.8157, 319.5, 239.5, {}}; }

DepthRegistrar DepthRegistrar::create(const RegistrationCalibration& calibration) {
    if (!calibration.depth.isValid())
        throw Error(calibration.source, std::nullopt,
                    "registration: invalid depth intrinsics " + calibration.depth.describe());
    if (!calibration.colour.isValid())
        throw Error(calibration.source, std::nullopt,
                    "registration: invalid colour intrinsics " + calibration.colour.describe());
    DepthRegistrar r;
    r.calibration_ = calibration;
    const CameraIntrinsics& k = calibration.depth;
    const std::size_t count = std::size_t(k.width) * std::size_t(k.height);
    r.rays_.resize(2 * count);
    if (k.hasDistortion()) {
        // Undo the depth camera's distortion once per pixel (cv::undistortPoints iterates the model).
        std::vector<cv::Point2d> pixels(count), normalised;
        for (int v = 0; v < k.height; ++v)
            for (int u = 0; u < k.width; ++u)
                pixels[std::size_t(v) * std::size_t(k.width) + std::size_t(u)] = {double(u), double(v)};
        const cv::Matx33d camera(k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0);
        const cv::Mat distortion(1, 5, CV_64FC1, const_cast<double*>(k.distortion.data()));
        cv::undistortPoints(pixels, normalised, camera, distortion);
        for (std::size_t i = 0; i < count; ++i) {
            r.rays_[2 * i] = normalised[i].x;
            r.rays_[2 * i + 1] = normalised[i].y;
        }
    } else {
        for (int v = 0; v < k.height; ++v)
            for (int u = 0; u < k.width; ++u) {
                const std::size_t i = std::size_t(v) * std::size_t(k.width) + std::size_t(u);
                r.rays_[2 * i] = (u - k.cx) / k.fx;
                r.rays_[2 * i + 1] = (v - k.cy) / k.fy;
            }
    }
    const glm::dmat3 rotation = glm::mat3_cast(calibration.colour_T_depth.rotation());
    for (int row = 0; row < 3; ++row)
        for (int column = 0; column < 3; ++column)
            r.r_[row * 3 + column] = rotation[column][row]; // glm is column-major
    const glm::dvec3& t = calibration.colour_T_depth.translation();
    r.t_[0] = t.x;
    r.t_[1] = t.y;
    r.t_[2] = t.z;
    return r;
}

void DepthRegistrar::registerInto(const cv::Mat& depth, double depthScaleMetres, cv::Mat& registered) const {
    const CameraIntrinsics& kd = calibration_.depth;
    const CameraIntrinsics& kc = calibration_.colour;
    LIGHTSKIN_ASSERT(
        depth.type() == CV_16UC1 && depth.cols == kd.width && depth.rows == kd.height,
        "lightskin::capture::DepthRegistrar::registerInto(): depth must be CV_16UC1 of the depth intrinsics' size");
    LIGHTSKIN_ASSERT(depthScaleMetres > 0.0,
                     "lightskin::capture::DepthRegistrar::registerInto(): depth scale must be positive");
    LIGHTSKIN_ASSERT(depth.data != registered.data,
                     "lightskin::capture::DepthRegistrar::registerInto(): in place is not supported");
    registered.create(kc.height, kc.width, CV_16UC1);
    registered.setTo(cv::Scalar::all(0));
    const double* R = r_;
    const double* t = t_;
    const double inverseScale = 1.0 / depthScaleMetres;
    const bool distort = kc.hasDistortion();
    const double k1 = kc.distortion[0], k2 = kc.distortion[1], p1 = kc.distortion[2], p2 = kc.distortion[3],
                 k3 = kc.distortion[4];
    // Pixel centres are integers (CameraIntrinsics' convention), so the nearest colour pixel of a
    // projection (x, y) is (round(x), round(y)); [-0.5, width - 0.5) is inside the image.
    const double maxU = kc.width - 0.5, maxV = kc.height - 0.5;
    for (int v = 0; v < kd.height; ++v) {
        const auto* row = depth.ptr<std::uint16_t>(v);
        const double* ray = rays_.data() + 2 * std::size_t(v) * std::size_t(kd.width);
        for (int u = 0; u < kd.width; ++u, ray += 2) {
            if (row[u] == 0) continue;
            const double z = row[u] * depthScaleMetres;
            const double px = ray[0] * z, py = ray[1] * z;
            const double qx = R[0] * px + R[1] * py + R[2] * z + t[0];
            const double qy = R[3] * px + R[4] * py + R[5] * z + t[1];
            const double qz = R[6] * px + R[7] * py + R[8] * z + t[2];
            if (!(qz > 0.0)) continue;
            const double inverseZ = 1.0 / qz;
            double x = qx * inverseZ, y = qy * inverseZ;
            if (distort) {
                const double r2 = x * x + y * y;
                const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
                const double xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
                const double yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
                x = xd;
                y = yd;
            }
            const double cu = kc.fx * x + kc.cx, cv = kc.fy * y + kc.cy;
            if (!(cu >= -0.5 && cu < maxU && cv >= -0.5 && cv < maxV)) continue;
            // Both are >= 0 here, so truncating x + 0.5 rounds to the nearest pixel (ties up).
            const int iu = std::min(kc.width - 1, int(cu + 0.5));
            const int iv = std::min(kc.height - 1, int(cv + 0.5));
            const auto value = static_cast<std::uint16_t>(std::clamp(qz * inverseScale + 0.5, 1.0, 65535.0));
            std::uint16_t& out = registered.ptr<std::uint16_t>(iv)[iu];
            if (out == 0 || value < out) out = value; // z-buffer: the nearest surface wins
        }
    }
}

} // namespace lightskin::capture
