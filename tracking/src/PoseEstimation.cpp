#include <lightskin/core/Error.h>
#include <lightskin/tracking/PoseEstimation.h>

#include <glm/gtc/quaternion.hpp>
#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

namespace lightskin::tracking {

namespace {

/// Corners in the tag frame, in TagDetection::corners order: bottom-left, bottom-right,
/// top-right, top-left of the printed tag (x right, y up, z out of the surface).
std::array<glm::dvec3, 4> tagCorners(double size) {
    const double h = 0.5 * size;
    return {glm::dvec3(-h, -h, 0.0), glm::dvec3(h, -h, 0.0), glm::dvec3(h, h, 0.0), glm::dvec3(-h, h, 0.0)};
}

cv::Matx33d cameraMatrix(const CameraIntrinsics& k) { return {k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0}; }

/// rvec/tvec (OpenCV: p_camera = R p_object + t) to the pose camera_T_object.
Pose poseFromRvecTvec(const cv::Vec3d& rvec, const cv::Vec3d& tvec) {
    cv::Matx33d r;
    cv::Rodrigues(rvec, r);
    glm::dmat3 rotation;
    for (int col = 0; col < 3; ++col)
        for (int row = 0; row < 3; ++row) rotation[col][row] = r(row, col);
    return Pose(glm::normalize(glm::quat_cast(rotation)), glm::dvec3(tvec[0], tvec[1], tvec[2]));
}

void rvecTvecFromPose(const Pose& camera_T_object, cv::Vec3d& rvec, cv::Vec3d& tvec) {
    const glm::dmat3 rotation = glm::mat3_cast(camera_T_object.rotation());
    cv::Matx33d r;
    for (int col = 0; col < 3; ++col)
        for (int row = 0; row < 3; ++row) r(row, col) = rotation[col][row];
    cv::Rodrigues(r, rvec);
    tvec = {camera_T_object.translation().x, camera_T_object.translation().y, camera_T_object.translation().z};
}

struct Correspondences {
    std::vector<cv::Point3d> world;
    std::vector<cv::Point2d> image;
};

double rmsError(const Pose& world_T_camera, const Correspondences& points, const CameraIntrinsics& k) {
    const Pose camera_T_world = world_T_camera.inverse();
    double sum = 0.0;
    for (std::size_t i = 0; i < points.world.size(); ++i) {
        const glm::dvec3 p = camera_T_world.transformPoint({points.world[i].x, points.world[i].y, points.world[i].z});
        if (p.z <= 1e-9) return std::numeric_limits<double>::infinity(); // behind the camera
        const glm::dvec2 uv = k.project(p);
        const double du = uv.x - points.image[i].x;
        const double dv = uv.y - points.image[i].y;
        sum += du * du + dv * dv;
    }
    return std::sqrt(sum / static_cast<double>(points.world.size()));
}

/// Both IPPE solutions for one tag, as world_T_camera.
void singleTagCandidates(const TagDetection& detection, const WorldTag& tag, const CameraIntrinsics& k,
                         std::vector<Pose>& out) {
    // SOLVEPNP_IPPE_SQUARE wants the object points in the order (-h, h), (h, h), (h, -h), (-h, -h):
    // our corners 3, 2, 1, 0.
    const auto corners = tagCorners(tag.sizeMetres);
    std::array<cv::Point3d, 4> objectPoints;
    std::array<cv::Point2d, 4> imagePoints;
    for (std::size_t i = 0; i < 4; ++i) {
        const std::size_t k3 = 3 - i;
        objectPoints[i] = {corners[k3].x, corners[k3].y, 0.0};
        imagePoints[i] = {detection.corners[k3].x, detection.corners[k3].y};
    }
    std::vector<cv::Vec3d> rvecs;
    std::vector<cv::Vec3d> tvecs;
    cv::solvePnPGeneric(cv::Mat(4, 1, CV_64FC3, objectPoints.data()), cv::Mat(4, 1, CV_64FC2, imagePoints.data()),
                        cameraMatrix(k), cv::noArray(), rvecs, tvecs, false, cv::SOLVEPNP_IPPE_SQUARE);
    for (std::size_t i = 0; i < rvecs.size(); ++i) {
        const Pose camera_T_tag = poseFromRvecTvec(rvecs[i], tvecs[i]);
        if (camera_T_tag.translation().z <= 0.0) continue;
        out.push_back(tag.world_T_tag * camera_T_tag.inverse());
    }
}

Pose refineLm(const Pose& world_T_camera, const Correspondences& points, const CameraIntrinsics& k) {
    cv::Vec3d rvec;
    cv::Vec3d tvec;
    rvecTvecFromPose(world_T_camera.inverse(), rvec, tvec);
    cv::solvePnPRefineLM(
        cv::Mat(static_cast<int>(points.world.size()), 1, CV_64FC3, const_cast<cv::Point3d*>(points.world.data())),
        cv::Mat(static_cast<int>(points.image.size()), 1, CV_64FC2, const_cast<cv::Point2d*>(points.image.data())),
        cameraMatrix(k), cv::noArray(), rvec, tvec);
    return poseFromRvecTvec(rvec, tvec).inverse();
}

/// The candidates (best first) and ambiguity ratio for one set of tags.
void solveCandidates(const std::vector<const TagDetection*>& used, const std::vector<const WorldTag*>& usedTags,
                     const CameraIntrinsics& intrinsics, PoseMeasurement& out) {
    out.candidates.clear();
    out.ambiguityRatio = std::numeric_limits<double>::infinity();
    Correspondences points;
    for (std::size_t t = 0; t < used.size(); ++t) {
        const auto corners = tagCorners(usedTags[t]->sizeMetres);
        for (std::size_t c = 0; c < 4; ++c) {
            const glm::dvec3 w = usedTags[t]->world_T_tag.transformPoint(corners[c]);
            points.world.emplace_back(w.x, w.y, w.z);
            points.image.emplace_back(used[t]->corners[c].x, used[t]->corners[c].y);
        }
    }

    std::vector<Pose> starts;
    for (std::size_t t = 0; t < used.size(); ++t) singleTagCandidates(*used[t], *usedTags[t], intrinsics, starts);

    if (used.size() == 1) {
        // Each IPPE solution polished by Levenberg-Marquardt on the 8 corner coordinates, unless that
        // slides it over to the other solution's side (then the two would merge and the ambiguity
        // would be hidden).
        std::array<double, 2> ippeErrors{std::numeric_limits<double>::infinity(),
                                         std::numeric_limits<double>::infinity()};
        for (std::size_t i = 0; i < starts.size(); ++i) {
            PoseCandidate candidate{starts[i], rmsError(starts[i], points, intrinsics)};
            if (i < 2) ippeErrors[i] = candidate.rmsErrorPx;
            const Pose refined = refineLm(starts[i], points, intrinsics);
            const double error = rmsError(refined, points, intrinsics);
            bool staysOnItsSide = true;
            for (std::size_t j = 0; j < starts.size(); ++j) {
                if (j != i &&
                    Pose::rotationAngleBetween(refined, starts[j]) <= Pose::rotationAngleBetween(refined, starts[i]))
                    staysOnItsSide = false;
            }
            if (staysOnItsSide && error < candidate.rmsErrorPx) candidate = {refined, error};
            out.candidates.push_back(candidate);
        }
        if (starts.size() == 2) {
            out.ambiguityRatio =
                std::max(ippeErrors[0], ippeErrors[1]) / std::max(std::min(ippeErrors[0], ippeErrors[1]), 1e-9);
        }
    } else {
        cv::Vec3d rvec;
        cv::Vec3d tvec;
        const bool solved =
            cv::solvePnP(cv::Mat(static_cast<int>(points.world.size()), 1, CV_64FC3, points.world.data()),
                         cv::Mat(static_cast<int>(points.image.size()), 1, CV_64FC2, points.image.data()),
                         cameraMatrix(intrinsics), cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_SQPNP);
        if (solved) starts.push_back(poseFromRvecTvec(rvec, tvec).inverse());
        std::vector<PoseCandidate> scored;
        for (const Pose& pose : starts) scored.push_back({pose, rmsError(pose, points, intrinsics)});
        std::sort(scored.begin(), scored.end(),
                  [](const PoseCandidate& a, const PoseCandidate& b) { return a.rmsErrorPx < b.rmsErrorPx; });
        // The best start and the best one that is a genuinely different pose (> 5 degrees away),
        // each refined on all corners.
        constexpr double distinctRadians = 5.0 * std::numbers::pi / 180.0;
        int refinements = 0;
        for (const PoseCandidate& candidate : scored) {
            if (!std::isfinite(candidate.rmsErrorPx)) break;
            // Starts near an existing candidate would refine onto it: skip them without the cost.
            const bool nearExisting =
                std::any_of(out.candidates.begin(), out.candidates.end(), [&](const PoseCandidate& c) {
                    return Pose::rotationAngleBetween(c.world_T_camera, candidate.world_T_camera) <= distinctRadians;
                });
            if (nearExisting) continue;
            if (++refinements > 4) break;
            const Pose refined = refineLm(candidate.world_T_camera, points, intrinsics);
            const double error = rmsError(refined, points, intrinsics);
            const PoseCandidate improved = error <= candidate.rmsErrorPx ? PoseCandidate{refined, error} : candidate;
            // Starts that converge onto an existing candidate are the same solution.
            const bool distinct =
                std::all_of(out.candidates.begin(), out.candidates.end(), [&](const PoseCandidate& c) {
                    return Pose::rotationAngleBetween(c.world_T_camera, improved.world_T_camera) > distinctRadians;
                });
            if (distinct) out.candidates.push_back(improved);
            if (out.candidates.size() == 2) break;
        }
    }
    out.candidates.erase(std::remove_if(out.candidates.begin(), out.candidates.end(),
                                        [](const PoseCandidate& c) { return !std::isfinite(c.rmsErrorPx); }),
                         out.candidates.end());
    std::sort(out.candidates.begin(), out.candidates.end(),
              [](const PoseCandidate& a, const PoseCandidate& b) { return a.rmsErrorPx < b.rmsErrorPx; });
    if (used.size() > 1 && out.candidates.size() == 2)
        out.ambiguityRatio = out.candidates[1].rmsErrorPx / std::max(out.candidates[0].rmsErrorPx, 1e-9);
}

/// RMS reprojection error of one tag's corners under a pose.
double tagRms(const Pose& world_T_camera, const TagDetection& detection, const WorldTag& tag,
              const CameraIntrinsics& intrinsics) {
    Correspondences points;
    const auto corners = tagCorners(tag.sizeMetres);
    for (std::size_t c = 0; c < 4; ++c) {
        const glm::dvec3 w = tag.world_T_tag.transformPoint(corners[c]);
        points.world.emplace_back(w.x, w.y, w.z);
        points.image.emplace_back(detection.corners[c].x, detection.corners[c].y);
    }
    return rmsError(world_T_camera, points, intrinsics);
}

} // namespace

void estimatePoseInto(const std::vector<TagDetection>& detections, const TagWorld& world,
                      const CameraIntrinsics& intrinsics, PoseMeasurement& out, double maxTagRmsPx) {
    LIGHTSKIN_ASSERT(intrinsics.isValid(), "intrinsics must be valid");
    out.tagsUsed.clear();
    out.unknownTags.clear();
    out.rejectedTags.clear();
    out.candidates.clear();
    out.ambiguityRatio = std::numeric_limits<double>::infinity();

    std::vector<const TagDetection*> used;
    std::vector<const WorldTag*> usedTags;
    for (const TagDetection& detection : detections) {
        const WorldTag* tag = world.find(detection.id);
        if (tag == nullptr) {
            if (out.unknownTags.empty() || out.unknownTags.back() != detection.id)
                out.unknownTags.push_back(detection.id);
            continue;
        }
        if (!used.empty() && used.back()->id == detection.id) continue; // duplicate id: keep the best margin
        used.push_back(&detection);
        usedTags.push_back(tag);
    }
    // A tag whose corners disagree with the others (a tag cut by the image border, a false
    // decode, a tag moved since the layout was measured) is dropped, worst first, until the rest
    // agree or one tag is left.
    while (!used.empty()) {
        solveCandidates(used, usedTags, intrinsics, out);
        if (used.size() == 1 || out.candidates.empty() || out.candidates[0].rmsErrorPx <= maxTagRmsPx) break;
        std::size_t worst = 0;
        double worstRms = -1.0;
        for (std::size_t t = 0; t < used.size(); ++t) {
            const double rms = tagRms(out.candidates[0].world_T_camera, *used[t], *usedTags[t], intrinsics);
            if (rms > worstRms) {
                worstRms = rms;
                worst = t;
            }
        }
        out.rejectedTags.push_back(used[worst]->id);
        used.erase(used.begin() + static_cast<std::ptrdiff_t>(worst));
        usedTags.erase(usedTags.begin() + static_cast<std::ptrdiff_t>(worst));
    }
    for (const TagDetection* detection : used) out.tagsUsed.push_back(detection->id);
    std::sort(out.rejectedTags.begin(), out.rejectedTags.end());
}

PoseMeasurement estimatePose(const std::vector<TagDetection>& detections, const TagWorld& world,
                             const CameraIntrinsics& intrinsics, double maxTagRmsPx) {
    PoseMeasurement out;
    estimatePoseInto(detections, world, intrinsics, out, maxTagRmsPx);
    return out;
}

double reprojectionRmsPx(const Pose& world_T_camera, const std::vector<TagDetection>& detections, const TagWorld& world,
                         const CameraIntrinsics& intrinsics) {
    Correspondences points;
    for (const TagDetection& detection : detections) {
        const WorldTag* tag = world.find(detection.id);
        if (tag == nullptr) continue;
        const auto corners = tagCorners(tag->sizeMetres);
        for (std::size_t c = 0; c < 4; ++c) {
            const glm::dvec3 w = tag->world_T_tag.transformPoint(corners[c]);
            points.world.emplace_back(w.x, w.y, w.z);
            points.image.emplace_back(detection.corners[c].x, detection.corners[c].y);
        }
    }
    if (points.world.empty()) return std::numeric_limits<double>::quiet_NaN();
    return rmsError(world_T_camera, points, intrinsics);
}

PoseUncertainty estimateUncertainty(const Pose& world_T_camera, const std::vector<TagDetection>& detections,
                                    const TagWorld& world, const CameraIntrinsics& intrinsics, double cornerSigmaPx,
                                    const std::vector<int>& tagIds) {
    Correspondences points;
    for (const TagDetection& detection : detections) {
        const WorldTag* tag = world.find(detection.id);
        if (tag == nullptr) continue;
        if (!tagIds.empty() && !std::binary_search(tagIds.begin(), tagIds.end(), detection.id)) continue;
        const auto corners = tagCorners(tag->sizeMetres);
        for (std::size_t c = 0; c < 4; ++c) {
            const glm::dvec3 w = tag->world_T_tag.transformPoint(corners[c]);
            points.world.emplace_back(w.x, w.y, w.z);
        }
    }
    PoseUncertainty result;
    if (points.world.size() < 4) return result;
    cv::Vec3d rvec;
    cv::Vec3d tvec;
    rvecTvecFromPose(world_T_camera.inverse(), rvec, tvec);
    std::vector<cv::Point2d> projected;
    cv::Mat jacobian; // 2N x (3 rotation + 3 translation + 2 focal + 2 centre + distortion)
    cv::projectPoints(cv::Mat(static_cast<int>(points.world.size()), 1, CV_64FC3, points.world.data()), rvec, tvec,
                      cameraMatrix(intrinsics), cv::noArray(), projected, jacobian);
    const cv::Mat poseJacobian = jacobian.colRange(0, 6);
    cv::Mat information = poseJacobian.t() * poseJacobian;
    cv::Mat covariance;
    if (cv::invert(information, covariance, cv::DECOMP_CHOLESKY) == 0.0) return result; // singular
    covariance *= cornerSigmaPx * cornerSigmaPx;
    cv::Mat eigenvalues;
    cv::eigen(covariance(cv::Rect(0, 0, 3, 3)), eigenvalues);
    result.rotationStdDegrees = std::sqrt(std::max(eigenvalues.at<double>(0), 0.0)) * 180.0 / std::numbers::pi;
    cv::eigen(covariance(cv::Rect(3, 3, 3, 3)), eigenvalues);
    result.translationStdMetres = std::sqrt(std::max(eigenvalues.at<double>(0), 0.0));

    // Every corner of the world, propagated: cov_uv = J cov J^T per corner in front of the camera.
    Correspondences worldPoints;
    const Pose camera_T_world = world_T_camera.inverse();
    for (const WorldTag& tag : world.tags()) {
        for (const glm::dvec3& corner : tagCorners(tag.sizeMetres)) {
            const glm::dvec3 w = tag.world_T_tag.transformPoint(corner);
            if (camera_T_world.transformPoint(w).z > 0.05) worldPoints.world.emplace_back(w.x, w.y, w.z);
        }
    }
    result.worldCornerStdPx = 0.0;
    if (worldPoints.world.empty()) return result;
    cv::projectPoints(cv::Mat(static_cast<int>(worldPoints.world.size()), 1, CV_64FC3, worldPoints.world.data()), rvec,
                      tvec, cameraMatrix(intrinsics), cv::noArray(), projected, jacobian);
    for (int i = 0; i < static_cast<int>(worldPoints.world.size()); ++i) {
        const cv::Mat rows = jacobian.rowRange(2 * i, 2 * i + 2).colRange(0, 6);
        const cv::Mat pointCovariance = rows * covariance * rows.t();
        cv::eigen(pointCovariance, eigenvalues);
        result.worldCornerStdPx =
            std::max(result.worldCornerStdPx, std::sqrt(std::max(eigenvalues.at<double>(0), 0.0)));
    }
    return result;
}

bool refinePoseWithDepth(const cv::Mat& depth, double depthScaleMetres, const CameraIntrinsics& intrinsics,
                         const TagDetection& detection, const WorldTag& tag, Pose& world_T_camera, int minSamples) {
    LIGHTSKIN_ASSERT(depth.type() == CV_16UC1, "depth must be CV_16UC1");
    if (depth.empty()) return false;
    // The quad shrunk by 15 % towards its centre: depth at the tag's edges mixes in the background.
    std::array<glm::dvec2, 4> quad;
    glm::dvec2 centre(0.0);
    for (const glm::dvec2& corner : detection.corners) centre += 0.25 * corner;
    for (std::size_t i = 0; i < 4; ++i) quad[i] = centre + 0.85 * (detection.corners[i] - centre);
    double minU = quad[0].x, maxU = quad[0].x, minV = quad[0].y, maxV = quad[0].y;
    for (const glm::dvec2& q : quad) {
        minU = std::min(minU, q.x);
        maxU = std::max(maxU, q.x);
        minV = std::min(minV, q.y);
        maxV = std::max(maxV, q.y);
    }
    const int u0 = std::max(0, static_cast<int>(std::ceil(minU)));
    const int u1 = std::min(depth.cols - 1, static_cast<int>(std::floor(maxU)));
    const int v0 = std::max(0, static_cast<int>(std::ceil(minV)));
    const int v1 = std::min(depth.rows - 1, static_cast<int>(std::floor(maxV)));
    if (u1 < u0 || v1 < v0) return false;
    // At most ~4000 samples: a regular stride over the bounding box.
    const double area = static_cast<double>(u1 - u0 + 1) * static_cast<double>(v1 - v0 + 1);
    const int stride = std::max(1, static_cast<int>(std::sqrt(area / 4000.0)));
    // Orientation of the quad (the sign of its area) for the inside test.
    double signedArea = 0.0;
    for (std::size_t i = 0; i < 4; ++i) {
        const glm::dvec2& a = quad[i];
        const glm::dvec2& b = quad[(i + 1) % 4];
        signedArea += a.x * b.y - b.x * a.y;
    }
    std::vector<glm::dvec3> samples;
    for (int v = v0; v <= v1; v += stride) {
        const auto* row = depth.ptr<std::uint16_t>(v);
        for (int u = u0; u <= u1; u += stride) {
            if (row[u] == 0) continue;
            const glm::dvec2 p(u, v);
            bool inside = true;
            for (std::size_t i = 0; i < 4 && inside; ++i) {
                const glm::dvec2 edge = quad[(i + 1) % 4] - quad[i];
                const glm::dvec2 toPoint = p - quad[i];
                inside = (edge.x * toPoint.y - edge.y * toPoint.x) * signedArea >= 0.0;
            }
            if (inside) samples.push_back(intrinsics.backProject(u, v, row[u] * depthScaleMetres));
        }
    }

    glm::dvec3 normal(0.0);
    glm::dvec3 mean(0.0);
    for (int pass = 0; pass < 2; ++pass) {
        if (static_cast<int>(samples.size()) < minSamples) return false;
        mean = glm::dvec3(0.0);
        for (const glm::dvec3& s : samples) mean += s;
        mean /= static_cast<double>(samples.size());
        cv::Matx33d covariance = cv::Matx33d::zeros();
        for (const glm::dvec3& s : samples) {
            const cv::Vec3d d(s.x - mean.x, s.y - mean.y, s.z - mean.z);
            covariance += d * d.t();
        }
        covariance *= 1.0 / static_cast<double>(samples.size());
        cv::Vec3d eigenvalues;
        cv::Matx33d eigenvectors;
        cv::eigen(covariance, eigenvalues, eigenvectors); // descending eigenvalues, rows = vectors
        normal = glm::normalize(glm::dvec3(eigenvectors(2, 0), eigenvectors(2, 1), eigenvectors(2, 2)));
        if (glm::dot(normal, mean) > 0.0) normal = -normal; // towards the camera
        const double rms = std::sqrt(std::max(eigenvalues[2], 0.0));
        if (pass == 1) {
            if (rms > 0.01) return false;
            break;
        }
        // Second pass without outliers (depth of an occluder or of the background).
        const double limit = std::max(2.5 * rms, 0.002);
        std::erase_if(samples, [&](const glm::dvec3& s) { return std::abs(glm::dot(s - mean, normal)) > limit; });
    }

    const Pose camera_T_tag = world_T_camera.inverse() * tag.world_T_tag;
    const glm::dvec3 imageNormal = camera_T_tag.transformDirection({0.0, 0.0, 1.0});
    const double tilt = std::acos(std::clamp(glm::dot(imageNormal, normal), -1.0, 1.0));
    if (tilt > 25.0 * std::numbers::pi / 180.0) return false;
    const glm::dvec3 centreRay = glm::normalize(camera_T_tag.translation());
    const double rayDotNormal = glm::dot(centreRay, normal);
    if (std::abs(rayDotNormal) < 1e-3) return false;
    const double distance = glm::dot(mean, normal) / rayDotNormal;
    const double imageDistance = glm::length(camera_T_tag.translation());
    if (!(std::abs(distance - imageDistance) <= 0.2 * imageDistance)) return false;

    // Shortest rotation taking imageNormal onto normal (the two are < 25 degrees apart).
    const glm::dvec3 axis = glm::cross(imageNormal, normal);
    const glm::dquat tiltCorrection =
        glm::normalize(glm::dquat(1.0 + glm::dot(imageNormal, normal), axis.x, axis.y, axis.z));
    const Pose corrected(tiltCorrection * camera_T_tag.rotation(), distance * centreRay);
    world_T_camera = tag.world_T_tag * corrected.inverse();
    return true;
}

} // namespace lightskin::tracking
