#include <lightskin/core/Error.h>
#include <lightskin/roommodel/RoomModel.h>

#include <opencv2/core.hpp>
#include <opencv2/rgbd/volume.hpp>

#include <cmath>
#include <sstream>

namespace lightskin::roommodel {

namespace {

std::string number(double value) {
    std::ostringstream text;
    text << value;
    return text.str();
}

cv::Matx44f toMatx(const Pose& pose) {
    const glm::dmat4 m = pose.matrix(); // column-major
    cv::Matx44f out;
    for (int row = 0; row < 4; ++row)
        for (int col = 0; col < 4; ++col) out(row, col) = float(m[col][row]);
    return out;
}

cv::kinfu::Intr toIntr(const CameraIntrinsics& intrinsics) {
    return cv::kinfu::Intr(float(intrinsics.fx), float(intrinsics.fy), float(intrinsics.cx), float(intrinsics.cy));
}

glm::ivec3 resolutionOf(const RoomModelSettings& s) {
    const glm::dvec3 cells = glm::ceil((s.boundsMax - s.boundsMin) / s.voxelSizeMetres);
    return glm::ivec3(cells);
}

} // namespace

void validate(const RoomModelSettings& s, const std::string& sourceName, const std::string& pointer) {
    const auto fail = [&](const std::string& key, const std::string& cause) {
        throw Error(sourceName, std::nullopt, pointer + "/" + key + ": " + cause);
    };
    // Written so that NaN fails too.
    if (!(s.voxelSizeMetres >= 0.002 && s.voxelSizeMetres <= 0.5))
        fail("voxelSizeMetres", "expected a number in [0.002, 0.5], got " + number(s.voxelSizeMetres));
    for (int axis = 0; axis < 3; ++axis)
        if (!(s.boundsMax[axis] - s.boundsMin[axis] >= s.voxelSizeMetres) || !std::isfinite(s.boundsMin[axis]) ||
            !std::isfinite(s.boundsMax[axis]))
            fail("bounds", "expected finite min < max, at least one voxel apart on every axis");
    if (!(s.truncationMetres >= 2.0 * s.voxelSizeMetres && s.truncationMetres <= 1.0))
        fail("truncationMetres", "expected a number in [2 voxels = " + number(2.0 * s.voxelSizeMetres) + ", 1], got " +
                                     number(s.truncationMetres));
    if (s.maxWeight < 1 || s.maxWeight > 255)
        fail("maxWeight", "expected an integer in [1, 255] (8-bit weights), got " + std::to_string(s.maxWeight));
    if (!(s.maxDepthMetres > 0.0 && s.maxDepthMetres <= 20.0))
        fail("maxDepthMetres", "expected a number in (0, 20], got " + number(s.maxDepthMetres));
    if (!(s.memoryBudgetMB > 0.0 && s.memoryBudgetMB <= 16384.0))
        fail("memoryBudgetMB", "expected a number in (0, 16384], got " + number(s.memoryBudgetMB));
    const glm::ivec3 r = resolutionOf(s);
    const double megabytes = double(r.x) * double(r.y) * double(r.z) * double(RoomModel::kBytesPerVoxel) * 1e-6;
    if (megabytes > s.memoryBudgetMB)
        fail("memoryBudgetMB", "the box needs " + std::to_string(r.x) + "x" + std::to_string(r.y) + "x" +
                                   std::to_string(r.z) + " voxels = " + number(megabytes) + " MB, over the budget of " +
                                   number(s.memoryBudgetMB) +
                                   " MB: raise it, shrink bounds or coarsen voxelSizeMetres");
}

struct RoomModel::Impl {
    RoomModelSettings settings;
    glm::ivec3 resolution{0};
    cv::Ptr<cv::kinfu::Volume> volume;
    cv::Mat points, normals; // raycast scratch, sized on first use
    int integratedFrames = 0;
};

RoomModel RoomModel::create(const RoomModelSettings& settings) {
    validate(settings, "room model", "");
    auto impl = std::make_unique<Impl>();
    impl->settings = settings;
    impl->resolution = resolutionOf(settings);
    const Pose world_T_volume(glm::dquat(1.0, 0.0, 0.0, 0.0), settings.boundsMin);
    // Ray steps of 0.75 voxel, OpenCV's default. Longer steps would halve the render time, but OpenCV 4.6's
    // raycast then misses or misplaces surfaces (1.5 voxels: 0.4 m errors in tests/roommodel).
    constexpr float kRaycastStepFactor = 0.75f;
    impl->volume = cv::kinfu::makeVolume(cv::kinfu::VolumeType::TSDF, float(settings.voxelSizeMetres),
                                         toMatx(world_T_volume), kRaycastStepFactor, float(settings.truncationMetres),
                                         settings.maxWeight, float(settings.maxDepthMetres),
                                         cv::Vec3i(impl->resolution.x, impl->resolution.y, impl->resolution.z));
    return RoomModel(std::move(impl));
}

RoomModel::RoomModel(std::unique_ptr<Impl> impl)
    : impl_(std::move(impl)) {}
RoomModel::RoomModel(RoomModel&&) noexcept = default;
RoomModel& RoomModel::operator=(RoomModel&&) noexcept = default;
RoomModel::~RoomModel() = default;

bool RoomModel::integrate(const cv::Mat& depthMetres, const CameraIntrinsics& intrinsics, const Pose& world_T_camera) {
    LIGHTSKIN_ASSERT(depthMetres.type() == CV_32FC1 && depthMetres.cols == intrinsics.width &&
                         depthMetres.rows == intrinsics.height,
                     "expected CV_32FC1 metres of the intrinsics' size");
    // OpenCV 4.6's dense TSDF integration (integrateVolumeUnit, tsdf_functions.cpp) steps its camera-space point
    // along the volume's z axis before using it and starts it at z = 0 whatever the first voxel: voxel z gets the
    // distance of position z + 1 - startZ. startZ is 0 unless the camera looks along +z (the volume's z axis is
    // the world's), so: frames that look along +z are skipped, and the others are integrated from a camera moved
    // by one voxel along +z, which cancels the step (tests/roommodel/RoomModelTest.cpp measures it on a floor).
    const glm::dvec3 forward = world_T_camera.transformDirection({0.0, 0.0, 1.0});
    if (forward.z > 0.0) return false;
    const Pose shifted(world_T_camera.rotation(),
                       world_T_camera.translation() + glm::dvec3(0.0, 0.0, impl_->settings.voxelSizeMetres));
    // depthFactor 1: the depth is already in metres.
    impl_->volume->integrate(depthMetres, 1.0f, toMatx(shifted), toIntr(intrinsics));
    ++impl_->integratedFrames;
    return true;
}

void RoomModel::renderDepthInto(const Pose& world_T_camera, const CameraIntrinsics& intrinsics,
                                cv::Mat& depthMetres) const {
    Impl& m = *impl_;
    const cv::Size size(intrinsics.width, intrinsics.height);
    // Points come back in the camera frame of world_T_camera, NaN where the ray meets no surface.
    m.volume->raycast(toMatx(world_T_camera), toIntr(intrinsics), size, m.points, m.normals);
    depthMetres.create(size, CV_32FC1);
    const int channels = m.points.channels();
    for (int y = 0; y < size.height; ++y) {
        const float* p = m.points.ptr<float>(y);
        float* d = depthMetres.ptr<float>(y);
        for (int x = 0; x < size.width; ++x) {
            const float z = p[x * channels + 2];
            d[x] = (z > 0.0f) ? z : 0.0f; // NaN compares false: missing
        }
    }
}

void RoomModel::reset() {
    impl_->volume->reset();
    impl_->integratedFrames = 0;
}

int RoomModel::integratedFrames() const noexcept { return impl_->integratedFrames; }
glm::ivec3 RoomModel::resolution() const noexcept { return impl_->resolution; }
std::size_t RoomModel::voxelBytes() const noexcept {
    const glm::ivec3 r = impl_->resolution;
    return std::size_t(r.x) * std::size_t(r.y) * std::size_t(r.z) * kBytesPerVoxel;
}
const RoomModelSettings& RoomModel::settings() const noexcept { return impl_->settings; }

} // namespace lightskin::roommodel
