#include <lightskin/core/Error.h>
#include <lightskin/roommodel/RoomModel.h>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/trigonometric.hpp>
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

/// The volume's axes in the world: z along `up` (a signed world axis), x and y the other two world axes,
/// right-handed; and its origin, the corner of the bounds where every volume coordinate is smallest.
Pose worldFromVolume(const RoomModelSettings& s) {
    const glm::dvec3 z = s.up;
    const glm::dvec3 x = std::abs(z.z) > 0.5   ? glm::dvec3(1.0, 0.0, 0.0)
                         : std::abs(z.y) > 0.5 ? glm::dvec3(0.0, 0.0, 1.0)
                                               : glm::dvec3(0.0, 1.0, 0.0);
    const glm::dvec3 y = glm::cross(z, x);
    glm::dmat4 m(1.0);
    m[0] = glm::dvec4(x, 0.0);
    m[1] = glm::dvec4(y, 0.0);
    m[2] = glm::dvec4(z, 0.0);
    glm::dvec3 origin;
    for (int a = 0; a < 3; ++a) // a world axis runs along +-one volume axis: start at its low end along that axis
        origin[a] = (x[a] + y[a] + z[a]) > 0.0 ? s.boundsMin[a] : s.boundsMax[a];
    m[3] = glm::dvec4(origin, 1.0);
    return Pose::fromMatrix(m);
}

glm::ivec3 resolutionOf(const RoomModelSettings& s) {
    const glm::dvec3 cells = glm::ceil((s.boundsMax - s.boundsMin) / s.voxelSizeMetres);
    // Volume axis i runs along the world axis its direction names.
    const glm::dmat3 axes(worldFromVolume(s).matrix());
    glm::ivec3 r;
    for (int i = 0; i < 3; ++i) {
        const glm::dvec3 a = glm::abs(axes[i]);
        r[i] = int(a.x * cells.x + a.y * cells.y + a.z * cells.z + 0.5);
    }
    return r;
}

} // namespace

void validate(const RoomModelSettings& s, const std::string& sourceName, const std::string& pointer) {
    const auto fail = [&](const std::string& key, const std::string& cause) {
        throw Error(sourceName, std::nullopt, pointer + "/" + key + ": " + cause);
    };
    // Written so that NaN fails too.
    const glm::dvec3 a = glm::abs(s.up);
    if (!(a.x + a.y + a.z == 1.0 && (a.x == 1.0 || a.y == 1.0 || a.z == 1.0)))
        fail("up", "expected a world axis: [0, 0, 1], [0, -1, 0], ...");
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
    std::vector<FusedView> views; // reserved to kMaxViews: no allocation per frame

    void rememberView(const Pose& world_T_camera, const CameraIntrinsics& intrinsics);
};

void RoomModel::Impl::rememberView(const Pose& world_T_camera, const CameraIntrinsics& intrinsics) {
    if (views.size() >= kMaxViews) return;
    const glm::dvec3 position = world_T_camera.translation();
    const glm::dvec3 forward = world_T_camera.transformDirection({0.0, 0.0, 1.0});
    const double minCos = std::cos(glm::radians(kViewSpacingDegrees));
    for (const FusedView& view : views) {
        const bool near = glm::length(view.world_T_camera.translation() - position) < kViewSpacingMetres;
        const bool sameWay = glm::dot(view.world_T_camera.transformDirection({0.0, 0.0, 1.0}), forward) > minCos;
        if (near && sameWay) return;
    }
    views.push_back({world_T_camera, intrinsics});
}

RoomModel RoomModel::create(const RoomModelSettings& settings) {
    validate(settings, "room model", "");
    auto impl = std::make_unique<Impl>();
    impl->settings = settings;
    impl->resolution = resolutionOf(settings);
    impl->views.reserve(kMaxViews);
    const Pose world_T_volume = worldFromVolume(settings);
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
    // the setting `up`), so: frames that look up are skipped, and the others are integrated from a camera moved
    // by one voxel up, which cancels the step (tests/roommodel/RoomModelTest.cpp measures it on a floor).
    const glm::dvec3 up = impl_->settings.up;
    if (glm::dot(world_T_camera.transformDirection({0.0, 0.0, 1.0}), up) > 0.0) return false;
    const Pose shifted(world_T_camera.rotation(), world_T_camera.translation() + up * impl_->settings.voxelSizeMetres);
    // depthFactor 1: the depth is already in metres.
    impl_->volume->integrate(depthMetres, 1.0f, toMatx(shifted), toIntr(intrinsics));
    ++impl_->integratedFrames;
    impl_->rememberView(world_T_camera, intrinsics);
    return true;
}

void RoomModel::renderDepthInto(const Pose& world_T_camera, const CameraIntrinsics& intrinsics, cv::Mat& depthMetres,
                                cv::Mat* normalsCamera) const {
    Impl& m = *impl_;
    const cv::Size size(intrinsics.width, intrinsics.height);
    // Points come back in the camera frame of world_T_camera, NaN where the ray meets no surface.
    m.volume->raycast(toMatx(world_T_camera), toIntr(intrinsics), size, m.points, m.normals);
    depthMetres.create(size, CV_32FC1);
    if (normalsCamera) normalsCamera->create(size, CV_32FC3);
    const int channels = m.points.channels(), normalChannels = m.normals.channels();
    for (int y = 0; y < size.height; ++y) {
        const float* p = m.points.ptr<float>(y);
        float* d = depthMetres.ptr<float>(y);
        for (int x = 0; x < size.width; ++x) {
            const float z = p[x * channels + 2];
            d[x] = (z > 0.0f) ? z : 0.0f; // NaN compares false: missing
            if (!normalsCamera) continue;
            const float* n = m.normals.ptr<float>(y) + x * normalChannels;
            normalsCamera->at<cv::Vec3f>(y, x) = d[x] > 0.0f ? cv::Vec3f(n[0], n[1], n[2]) : cv::Vec3f(0.f, 0.f, 0.f);
        }
    }
}

void RoomModel::reset() {
    impl_->volume->reset();
    impl_->integratedFrames = 0;
    impl_->views.clear();
}

int RoomModel::integratedFrames() const noexcept { return impl_->integratedFrames; }
glm::ivec3 RoomModel::resolution() const noexcept { return impl_->resolution; }
std::size_t RoomModel::voxelBytes() const noexcept {
    const glm::ivec3 r = impl_->resolution;
    return std::size_t(r.x) * std::size_t(r.y) * std::size_t(r.z) * kBytesPerVoxel;
}
const RoomModelSettings& RoomModel::settings() const noexcept { return impl_->settings; }
const std::vector<FusedView>& RoomModel::views() const noexcept { return impl_->views; }

} // namespace lightskin::roommodel
