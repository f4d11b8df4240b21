#pragma once
// Rigid transforms with their frames in the name. `Pose world_T_camera` maps a point given in
// camera coordinates to world coordinates: p_world = world_T_camera * p_camera.
// Camera frame convention (OpenCV/RGB-D): x right, y down, z forward along the optical axis.
// World frame: defined by the AprilTag layout (tracking) or the recording's ground truth.
// Units: metres.

#include <glm/gtc/quaternion.hpp>
#include <glm/mat4x4.hpp>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace lightskin {

class Pose {
public:
    /// Identity.
    Pose() = default;
    Pose(const glm::dquat& rotation, const glm::dvec3& translation);
    /// From a 4x4 rigid matrix (column-major, glm). The rotation part is re-orthonormalised.
    static Pose fromMatrix(const glm::dmat4& matrix);

    const glm::dquat& rotation() const noexcept { return rotation_; }
    const glm::dvec3& translation() const noexcept { return translation_; }

    glm::dmat4 matrix() const;
    glm::mat4 matrixFloat() const { return glm::mat4(matrix()); }
    Pose inverse() const;
    glm::dvec3 transformPoint(const glm::dvec3& point) const { return rotation_ * point + translation_; }
    glm::dvec3 transformDirection(const glm::dvec3& direction) const { return rotation_ * direction; }

    /// a_T_c = a_T_b * b_T_c
    friend Pose operator*(const Pose& a_T_b, const Pose& b_T_c);

    /// Angle of the relative rotation between two poses, radians in [0, pi].
    static double rotationAngleBetween(const Pose& a, const Pose& b);
    /// Distance between the translations, metres.
    static double translationDistance(const Pose& a, const Pose& b);

private:
    glm::dquat rotation_{1.0, 0.0, 0.0, 0.0};
    glm::dvec3 translation_{0.0};
};

} // namespace lightskin
