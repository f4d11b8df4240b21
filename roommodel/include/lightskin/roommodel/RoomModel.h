#pragma once
// A memory of the room's surfaces: a truncated signed distance field (TSDF) fused over time from registered depth
// at known camera poses, and rendered back as depth from any pose (for depth tracking against the model).
//
// Backed by OpenCV contrib's KinectFusion volume (cv::kinfu::Volume, VolumeType::TSDF: a dense grid of 2-byte
// voxels, 8-bit distance and 8-bit weight). Why this one and not a hashed TSDF or Open3D: docs/ARCHITECTURE.md,
// "Room memory".
//
// Frames and units: the world frame is the tracking world (metres); camera poses are world_T_camera of the
// camera the depth is registered to (x right, y down, z forward). Depth images are CV_32FC1 metres along z;
// 0 is missing (NaN is not allowed). Lens distortion is ignored (pinhole model): undistort depth first for strong
// lenses.
//
// Update rule for surfaces that change: each voxel keeps a running average of its signed distance over at most
// `maxWeight` observations, so a surface that moved is overwritten after about maxWeight frames that see it
// (and space seen empty is carved as soon as the free-space distance outweighs the old one).
//
// Ownership: a RoomModel owns its voxels (allocated once, in create(); the memory budget bounds them). Move-only.
// Not thread-safe: one thread integrates and renders.

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>

#include <glm/vec3.hpp>
#include <opencv2/core/mat.hpp>

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace lightskin::roommodel {

struct RoomModelSettings {
    /// The box of the world the model covers, world coordinates, metres. Surfaces outside are not remembered.
    glm::dvec3 boundsMin{0.0};
    glm::dvec3 boundsMax{4.0, 4.0, 3.0};
    /// The world's up, a signed world axis ([0, 0, 1] for a z-up world, [0, -1, 0] for ICL-NUIM's). Cameras
    /// looking up (optical axis with a positive component along it) are not fused (integrate()).
    glm::dvec3 up{0.0, 0.0, 1.0};
    /// Edge of a voxel, metres. Smaller = finer surfaces, cubically more memory and integration time: the whole
    /// grid is swept per fused frame. 4 cm: a 4.6 x 4.1 x 3.2 m room fuses in 4.7 ms of CPU per frame, at 2 cm
    /// in 32 ms, with the same depth-tracking error (1.6 mm; docs/ROOMMODEL.md).
    double voxelSizeMetres = 0.04;
    /// Distances beyond this from a surface are truncated, metres. At least 2 voxels (the field must be
    /// sampled on both sides of a surface) and a few depth-noise sigmas (0.12 m: 3 voxels, 8 sigma at 3 m for
    /// the Kinect v1 axial noise, FACTS.md: 0.0012 + 0.0019 (z - 0.4)^2 = 0.014 m at 3 m).
    double truncationMetres = 0.12;
    /// Observations a voxel averages at most (1..255: the weight is 8-bit). Lower = faster forgetting of
    /// surfaces that changed, more noise.
    int maxWeight = 64;
    /// Depth beyond this is not integrated, metres (far Kinect depth is noisy).
    double maxDepthMetres = 4.0;
    /// Upper bound of the voxel memory, MB (10^6 bytes). create() refuses a box that needs more.
    double memoryBudgetMB = 64.0;
};

/// Throws lightskin::Error (source `sourceName`, cause "<pointer>/<key>: ...") for settings out of range.
void validate(const RoomModelSettings& settings, const std::string& sourceName, const std::string& pointer);

/// A camera the model was fused from (its pose and the intrinsics of the depth it fused).
struct FusedView {
    Pose world_T_camera;
    CameraIntrinsics intrinsics;
};

class RoomModel {
public:
    /// views() keeps a fused frame whose camera is at least this far from every kept view (position, metres,
    /// or viewing direction, degrees), up to kMaxViews: views that together saw what the fused frames saw.
    static constexpr double kViewSpacingMetres = 0.25, kViewSpacingDegrees = 15.0;
    static constexpr std::size_t kMaxViews = 128;

    /// Bytes of one voxel of cv::kinfu's TSDF volume (int8 distance + uint8 weight).
    static constexpr std::size_t kBytesPerVoxel = 2;

    /// Throws lightskin::Error naming the key for invalid settings or a box over the memory budget.
    static RoomModel create(const RoomModelSettings& settings);

    RoomModel(RoomModel&&) noexcept;
    RoomModel& operator=(RoomModel&&) noexcept;
    ~RoomModel();

    /// Fuses one depth image (CV_32FC1 metres, intrinsics of its size) seen from world_T_camera. Returns false,
    /// and fuses nothing, for a camera looking up (along RoomModelSettings::up): OpenCV 4.6's
    /// integration misplaces those (RoomModel.cpp says how); a room is seen from above often enough.
    bool integrate(const cv::Mat& depthMetres, const CameraIntrinsics& intrinsics, const Pose& world_T_camera);
    /// Renders the model's surfaces as depth (CV_32FC1 metres along z, 0 where no surface is hit) seen from
    /// world_T_camera with `intrinsics` (their width and height give the image size). Reuses `depthMetres`.
    /// With `normalsCamera`: also the surfaces' unit normals there, camera frame, CV_32FC3 (zero where no surface).
    void renderDepthInto(const Pose& world_T_camera, const CameraIntrinsics& intrinsics, cv::Mat& depthMetres,
                         cv::Mat* normalsCamera = nullptr) const;
    /// Forgets every surface and view (keeps the memory).
    void reset();
    /// Cameras of the fused frames, spaced as kViewSpacingMetres / kViewSpacingDegrees say, in fusion order: the
    /// surfaces seen from them are what a saved model holds (RoomModelFile.h).
    const std::vector<FusedView>& views() const noexcept;

    /// Frames integrated since creation or reset().
    int integratedFrames() const noexcept;
    /// Voxels along x, y, z.
    glm::ivec3 resolution() const noexcept;
    /// Memory of the voxels, bytes.
    std::size_t voxelBytes() const noexcept;
    const RoomModelSettings& settings() const noexcept;

private:
    struct Impl;
    explicit RoomModel(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

} // namespace lightskin::roommodel
