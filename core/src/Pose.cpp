#include <lightskin/core/Pose.h>

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>

namespace lightskin {

Pose::Pose(const glm::dquat& rotation, const glm::dvec3& translation)
    : rotation_(glm::normalize(rotation)), translation_(translation) {}

Pose Pose::fromMatrix(const glm::dmat4& matrix) {
    // quat_cast of a slightly non-orthonormal matrix followed by normalisation gives the nearest
    // rotation closely enough for poses from PnP or files with 6-7 significant digits.
    return Pose(glm::normalize(glm::quat_cast(glm::dmat3(matrix))), glm::dvec3(matrix[3]));
}

glm::dmat4 Pose::matrix() const {
    glm::dmat4 result = glm::mat4_cast(rotation_);
    result[3] = glm::dvec4(translation_, 1.0);
    return result;
}

Pose Pose::inverse() const {
    const glm::dquat inverseRotation = glm::conjugate(rotation_);
    return Pose(inverseRotation, -(inverseRotation * translation_));
}

Pose operator*(const Pose& a_T_b, const Pose& b_T_c) {
    return Pose(a_T_b.rotation_ * b_T_c.rotation_, a_T_b.rotation_ * b_T_c.translation_ + a_T_b.translation_);
}

double Pose::rotationAngleBetween(const Pose& a, const Pose& b) {
    const glm::dquat relative = glm::conjugate(a.rotation_) * b.rotation_;
    // atan2 stays accurate for tiny angles where acos(w) loses half the digits; |w| handles the
    // double cover (q and -q are the same rotation).
    const double sinHalf = glm::length(glm::dvec3(relative.x, relative.y, relative.z));
    return 2.0 * std::atan2(sinHalf, std::abs(relative.w));
}

double Pose::translationDistance(const Pose& a, const Pose& b) { return glm::length(a.translation_ - b.translation_); }

} // namespace lightskin
