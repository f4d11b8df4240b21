// CPU reference of ValGenerator in double precision. Normals from PCL's
// IntegralImageNormalEstimation (an independent implementation of the 3D-gradient normal), all
// other per-pixel math as documented in ValGenerator.h.
#include <lightskin/core/Error.h>
#include <lightskin/gi/common/ValGenerator.h>
#include <lightskin/gi/reference/ValGeneratorReference.h>

#include <pcl/features/integral_image_normal.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cmath>
#include <limits>
#include <numbers>

namespace lightskin::gi {

std::vector<ReferenceVal> generateValsReference(const cv::Mat& depth, double depthScaleMetres, const cv::Mat& colourBgr,
                                                const CameraIntrinsics& K, const Pose& world_T_camera,
                                                const ValGeneratorSettings& settings) {
    validate(settings);
    if (depth.empty() || (depth.type() != CV_16UC1 && depth.type() != CV_32FC1))
        throw Error("generateValsReference", std::nullopt, "depth must be CV_16UC1 or CV_32FC1");
    if (colourBgr.size() != depth.size() || colourBgr.type() != CV_8UC3)
        throw Error("generateValsReference", std::nullopt, "colour must be CV_8UC3 (BGR) of the depth map's size");
    const int width = depth.cols, height = depth.rows;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const auto depthAt = [&](int u, int v) -> double {
        const double z = depth.type() == CV_16UC1 ? double(depth.at<std::uint16_t>(v, u)) * depthScaleMetres
                                                  : double(depth.at<float>(v, u));
        return (z > double(settings.minDepth) && z <= double(settings.maxDepth)) ? z : nan;
    };

    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(
        new pcl::PointCloud<pcl::PointXYZ>(std::uint32_t(width), std::uint32_t(height)));
    cloud->is_dense = false;
    for (int v = 0; v < height; ++v)
        for (int u = 0; u < width; ++u) {
            const double z = depthAt(u, v);
            pcl::PointXYZ& point = cloud->at(u, v);
            if (std::isnan(z)) {
                point.x = point.y = point.z = std::numeric_limits<float>::quiet_NaN();
            } else {
                const glm::dvec3 p = K.backProject(u, v, z);
                point.x = float(p.x);
                point.y = float(p.y);
                point.z = float(p.z);
            }
        }
    pcl::PointCloud<pcl::Normal> normals;
    pcl::IntegralImageNormalEstimation<pcl::PointXYZ, pcl::Normal> estimator;
    estimator.setNormalEstimationMethod(estimator.AVERAGE_3D_GRADIENT);
    estimator.setMaxDepthChangeFactor(settings.pclMaxDepthChangeFactor);
    estimator.setNormalSmoothingSize(float(2 * settings.normalWindowRadius));
    estimator.setDepthDependentSmoothing(false);
    estimator.setInputCloud(cloud);
    estimator.compute(normals);

    const int s = settings.stride;
    const glm::dmat4 pose = world_T_camera.matrix();
    const glm::dmat3 rotation(pose);
    std::vector<ReferenceVal> out;
    out.reserve(std::size_t((width / s) * (height / s)));
    for (int j = 0; j < height / s; ++j)
        for (int i = 0; i < width / s; ++i) {
            const int u = i * s + s / 2, v = j * s + s / 2;
            const double z = depthAt(u, v);
            const pcl::Normal& pn = normals.at(u, v);
            if (std::isnan(z) || !std::isfinite(pn.normal_x) || !std::isfinite(pn.normal_y) ||
                !std::isfinite(pn.normal_z))
                continue;
            glm::dvec3 n(pn.normal_x, pn.normal_y, pn.normal_z);
            const double nLength = glm::length(n);
            if (!(nLength > 0.0)) continue;
            n /= nLength;
            double zBlock = z;
            if (s % 2 == 0) {
                const double z00 = depthAt(u - 1, v - 1), z10 = depthAt(u, v - 1), z01 = depthAt(u - 1, v);
                if (std::isnan(z00) || std::isnan(z10) || std::isnan(z01)) continue;
                zBlock = 0.25 * (z00 + z10 + z01 + z);
            }
            const double centre = 0.5 * double(s - 1);
            const glm::dvec3 p = K.backProject(i * s + centre, j * s + centre, zBlock);
            const glm::dvec3 ray = glm::normalize(p);
            if (glm::dot(n, ray) > 0.0) n = -n;
            const double footprint = (s * zBlock / K.fx) * (s * zBlock / std::abs(K.fy));
            const double cosTheta = std::max(-glm::dot(n, ray), double(settings.minCosine));
            const double area = footprint * ray.z / cosTheta;
            glm::dvec3 colour(0.0);
            for (int y = j * s; y < j * s + s; ++y)
                for (int x = i * s; x < i * s + s; ++x) {
                    const cv::Vec3b bgr = colourBgr.at<cv::Vec3b>(y, x);
                    colour += glm::dvec3(srgbToLinear(bgr[2] / 255.0), srgbToLinear(bgr[1] / 255.0),
                                         srgbToLinear(bgr[0] / 255.0));
                }
            colour /= double(s * s);
            ReferenceVal val;
            val.position = glm::dvec3(pose * glm::dvec4(p, 1.0));
            val.area = area;
            val.normal = glm::normalize(rotation * n);
            val.flux = std::numbers::pi * double(settings.exposure) * colour * area;
            val.pixelIndex = std::uint32_t(v * width + u);
            out.push_back(val);
        }
    return out;
}

} // namespace lightskin::gi
