#include <lightskin/core/Error.h>
#include <lightskin/tracking/SyntheticTagImage.h>
#include <lightskin/tracking/TagFamily.h>

#include <glm/gtc/quaternion.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <numbers>

namespace lightskin::tracking {

namespace {
constexpr int texturePixelsPerCell = 16;
}

cv::Mat renderSyntheticTagImage(const TagWorld& world, const CameraIntrinsics& intrinsics, const Pose& world_T_camera,
                                const SyntheticTagImageSettings& settings) {
    LIGHTSKIN_ASSERT(intrinsics.isValid(), "intrinsics must be valid");
    LIGHTSKIN_ASSERT(settings.supersampling >= 1 && settings.supersampling <= 8, "supersampling must be 1..8");
    const int s = settings.supersampling;
    const double sd = static_cast<double>(s);
    cv::Mat canvas(intrinsics.height * s, intrinsics.width * s, CV_8UC1, cv::Scalar(settings.background));
    if (!settings.backgroundImage.empty()) {
        LIGHTSKIN_ASSERT(settings.backgroundImage.type() == CV_8UC1 &&
                             settings.backgroundImage.cols == intrinsics.width &&
                             settings.backgroundImage.rows == intrinsics.height,
                         "backgroundImage must be CV_8UC1 of the output size");
        cv::resize(settings.backgroundImage, canvas, canvas.size(), 0.0, 0.0, cv::INTER_NEAREST);
    }
    // Pinhole of the supersampled image; pixel centres stay consistent: c' = (c + 0.5) s - 0.5.
    const cv::Matx33d k(intrinsics.fx * sd, 0.0, (intrinsics.cx + 0.5) * sd - 0.5, 0.0, intrinsics.fy * sd,
                        (intrinsics.cy + 0.5) * sd - 0.5, 0.0, 0.0, 1.0);
    const TagLayout layout = tagLayout(world.family());
    const Pose camera_T_world = world_T_camera.inverse();
    const double half = 0.5 * layout.totalCells;
    const double t = texturePixelsPerCell;

    for (const WorldTag& tag : world.tags()) {
        const Pose camera_T_tag = camera_T_world * tag.world_T_tag;
        const double cell = layout.cellSizeMetres(tag.sizeMetres);
        bool inFront = true;
        for (const double x : {-half, half})
            for (const double y : {-half, half})
                inFront = inFront && camera_T_tag.transformPoint({x * cell, y * cell, 0.0}).z > 0.01;
        if (!inFront) continue;

        cv::Mat bitmap = renderTagBitmap(world.family(), tag.id);
        cv::Mat texture;
        cv::resize(bitmap, texture, {}, t, t, cv::INTER_NEAREST);
        // 0 -> black level, 255 -> white level.
        texture.convertTo(texture, CV_8U, (settings.white - settings.black) / 255.0, settings.black);

        // Tag-plane point (X, Y) in metres -> texture pixel: column (X / cell + half) t - 0.5,
        // row (half - Y / cell) t - 0.5 (the tag's y points up, rows go down).
        const cv::Matx33d tagFromTexture =
            cv::Matx33d(t / cell, 0.0, half * t - 0.5, 0.0, -t / cell, half * t - 0.5, 0.0, 0.0, 1.0).inv();
        const glm::dmat3 r = glm::mat3_cast(camera_T_tag.rotation());
        const glm::dvec3& p = camera_T_tag.translation();
        const cv::Matx33d planeToCamera(r[0][0], r[1][0], p.x, r[0][1], r[1][1], p.y, r[0][2], r[1][2], p.z);
        const cv::Matx33d homography = k * planeToCamera * tagFromTexture;
        cv::warpPerspective(texture, canvas, cv::Mat(homography), canvas.size(), cv::INTER_LINEAR,
                            cv::BORDER_TRANSPARENT);
    }

    cv::Mat image;
    if (s == 1) {
        image = canvas;
    } else {
        cv::resize(canvas, image, cv::Size(intrinsics.width, intrinsics.height), 0.0, 0.0, cv::INTER_AREA);
    }
    if (settings.motionBlurPx > 0.0) {
        // A normalised line kernel of the given length and direction, odd size, centred.
        const int size = 2 * static_cast<int>(std::ceil(0.5 * settings.motionBlurPx)) + 1;
        cv::Mat kernel(size, size, CV_32F, cv::Scalar(0.0f));
        const double angle = settings.motionBlurAngleDegrees * std::numbers::pi / 180.0;
        const int samples = 8 * size;
        for (int i = 0; i < samples; ++i) {
            const double f = (static_cast<double>(i) / (samples - 1) - 0.5) * settings.motionBlurPx;
            const int x = static_cast<int>(std::lround(0.5 * (size - 1) + f * std::cos(angle)));
            const int y = static_cast<int>(std::lround(0.5 * (size - 1) + f * std::sin(angle)));
            kernel.at<float>(y, x) += 1.0f;
        }
        kernel /= cv::sum(kernel)[0];
        cv::filter2D(image, image, -1, kernel, cv::Point(-1, -1), 0.0, cv::BORDER_REPLICATE);
    }
    if (settings.noiseSigma > 0.0) {
        cv::Mat noise(image.size(), CV_32F);
        cv::RNG rng(settings.noiseSeed);
        rng.fill(noise, cv::RNG::NORMAL, 0.0, settings.noiseSigma);
        cv::Mat value;
        image.convertTo(value, CV_32F);
        value += noise;
        value.convertTo(image, CV_8U); // saturating
    }
    return image;
}

Pose lookAt(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& up) {
    const glm::dvec3 z = glm::normalize(target - eye);
    glm::dvec3 y = -up - glm::dot(-up, z) * z;
    LIGHTSKIN_ASSERT(glm::length(y) > 1e-9, "up must not be parallel to the viewing direction");
    y = glm::normalize(y);
    const glm::dvec3 x = glm::cross(y, z);
    const glm::dmat3 rotation(x, y, z); // columns: camera axes in the world
    return Pose(glm::quat_cast(rotation), eye);
}

} // namespace lightskin::tracking
