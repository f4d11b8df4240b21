#pragma once
// One frame's camera pose from tag detections, without history (PoseTracker adds the history).
//
// Single tag: a planar square has two pose solutions that can both fit the corners (the planar
// ambiguity, worst for small or distant tags seen nearly fronto-parallel). Both come from
// OpenCV's solvePnPGeneric(SOLVEPNP_IPPE_SQUARE) and are returned best first with their
// reprojection errors; the caller decides with history (PoseTracker) when they are close.
// Bundles: every visible corner of every known tag in one PnP; starting points are SQPnP and each
// tag's two IPPE solutions, the best by total reprojection error is refined with Levenberg-
// Marquardt (solvePnPRefineLM); the runner-up is kept as the alternative candidate.

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>
#include <lightskin/tracking/TagDetector.h>
#include <lightskin/tracking/TagWorld.h>

#include <opencv2/core/mat.hpp>

#include <limits>
#include <vector>

namespace lightskin::tracking {

struct PoseCandidate {
    Pose world_T_camera;
    /// Root-mean-square corner reprojection error over all used corners, pixels.
    double rmsErrorPx = std::numeric_limits<double>::infinity();
};

struct PoseMeasurement {
    /// Ids of the detections that are in the world and took part, ascending.
    std::vector<int> tagsUsed;
    /// Ids that were detected but are not in the world (ignored), ascending.
    std::vector<int> unknownTags;
    /// Ids in the world whose corners disagreed with the other tags' (dropped), ascending.
    std::vector<int> rejectedTags;
    /// Best first. Empty when no known tag was visible; one or two entries otherwise.
    std::vector<PoseCandidate> candidates;

    bool valid() const noexcept { return !candidates.empty(); }
    /// How clearly the best solution beats the other one: second / best reprojection error, both
    /// straight from IPPE for a single tag (before the Levenberg-Marquardt polish, which could move
    /// only one of them), both refined for a bundle; infinity with one candidate. Close to 1 means
    /// the two solutions explain the corners equally well: the choice between them is a guess.
    double ambiguityRatio = std::numeric_limits<double>::infinity();
};

/// Estimates world_T_camera from `detections` whose corners are in an UNDISTORTED image of the
/// pinhole camera `intrinsics` (distortion ignored). Detections of ids the world does not
/// contain are listed in unknownTags; if several detections share a known id (a duplicate print or
/// a false positive), the first (highest decision margin) is used. With several tags, while the
/// joint fit's RMS error exceeds `maxTagRmsPx`, the tag that fits worst is dropped (rejectedTags):
/// a tag cut by the image border, a false decode or a tag that moved. Writes into `out`, reusing
/// its buffers.
void estimatePoseInto(const std::vector<TagDetection>& detections, const TagWorld& world,
                      const CameraIntrinsics& intrinsics, PoseMeasurement& out, double maxTagRmsPx = 3.0);
PoseMeasurement estimatePose(const std::vector<TagDetection>& detections, const TagWorld& world,
                             const CameraIntrinsics& intrinsics, double maxTagRmsPx = 3.0);

/// First-order (Gauss-Newton) uncertainty of a PnP pose, from the corner Jacobian and an assumed
/// corner noise: covariance = sigma^2 (J^T J)^-1 over the 6 pose parameters.
struct PoseUncertainty {
    /// Standard deviation of the rotation along its worst axis, degrees. Large (> 0.5) for
    /// nearly fronto-parallel, small or distant single tags: the pose is poorly determined.
    double rotationStdDegrees = std::numeric_limits<double>::infinity();
    /// Standard deviation of the world origin's position in the camera frame along its worst
    /// axis, metres (mostly along the viewing ray). The camera's position in the world also moves
    /// with the rotation error times the distance (lever arm).
    double translationStdMetres = std::numeric_limits<double>::infinity();
    /// Largest standard deviation (pixels, worst axis) of the projection of any corner of any tag
    /// of the WORLD - also the tags not seen this frame - that lies in front of the camera: how
    /// well the pose places the world's content in this image, not only the measured tags. For a
    /// single-tag world it stays near the corner noise (the seen corners are what was measured);
    /// for a bundle seen through one small, distant tag the other tags' corners move with the
    /// rotation uncertainty times their distance from the seen tag (PoseTracker's
    /// maxWorldCornerStdPx refuses such poses).
    double worldCornerStdPx = std::numeric_limits<double>::infinity();
};

/// Uncertainty of `world_T_camera` given the corners of the detections whose ids are in `tagIds`
/// (ascending; all detections in the world when empty) and a corner noise of `cornerSigmaPx`
/// pixels (PoseTracker uses max(RMS reprojection error, 0.1 px)).
PoseUncertainty estimateUncertainty(const Pose& world_T_camera, const std::vector<TagDetection>& detections,
                                    const TagWorld& world, const CameraIntrinsics& intrinsics, double cornerSigmaPx,
                                    const std::vector<int>& tagIds = {});

/// RMS reprojection error (pixels) of `world_T_camera` on the used corners of `detections`.
double reprojectionRmsPx(const Pose& world_T_camera, const std::vector<TagDetection>& detections, const TagWorld& world,
                         const CameraIntrinsics& intrinsics);

/// Optional depth-aided refinement for a single-tag measurement: fits a plane to the registered
/// depth inside the tag's quad (depth CV_16UC1 in the colour camera's pixels, `depthScaleMetres`
/// per unit, 0 = missing) and corrects the pose so that the tag lies on that plane: the tag
/// normal is rotated onto the plane normal (tilt) and the tag centre is moved along its viewing
/// ray onto the plane (distance); the in-plane rotation stays the image's. Returns false and
/// leaves the pose unchanged when there are fewer than `minSamples` valid depth pixels, the plane
/// fit residual exceeds 1 cm, or depth and image disagree by more than 20 % in distance or 25
/// degrees in tilt (then the depth is not of the tag: a hole, an occluder or a wrong registration).
bool refinePoseWithDepth(const cv::Mat& depth, double depthScaleMetres, const CameraIntrinsics& intrinsics,
                         const TagDetection& detection, const WorldTag& tag, Pose& world_T_camera, int minSamples = 50);

} // namespace lightskin::tracking
