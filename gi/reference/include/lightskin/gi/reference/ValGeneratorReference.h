#pragma once
// The CPU reference of gi::ValGenerator in double precision (tests and benchmarks only).

#include <lightskin/gi/common/ValGenerator.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <vector>

namespace lightskin::gi {

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

} // namespace lightskin::gi
