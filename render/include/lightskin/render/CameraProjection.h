#pragma once
// The colour camera as an OpenGL projection.
// Camera frame: OpenCV (x right, y down, z forward along the optical axis, metres). Pixel (u,v): OpenCV
// convention, (0,0) the centre of the top-left pixel, v downwards. GL framebuffers' row 0 is the *bottom* row;
// images read back with gl::Readback are flipped, so image row v = H-1-(GL window row). clip_T_camera maps
// OpenCV camera-frame points straight to GL clip space with pixel centres on pixel centres; distortion is not
// part of it (the compositor warps the rendered layers). The matrix and why front faces keep their winding:
// docs/ARCHITECTURE.md, "Camera projection".

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>

#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace lightskin::render {

/// `nearMetres` > 0, `farMetres` > `nearMetres`; intrinsics must be valid (fy may be negative).
glm::dmat4 clipFromCamera(const CameraIntrinsics& intrinsics, double nearMetres, double farMetres);

/// clip_T_world = clipFromCamera * camera_T_world, with camera_T_world = inverse(world_T_camera).
glm::dmat4 clipFromWorld(const CameraIntrinsics& intrinsics, const Pose& world_T_camera, double nearMetres,
                         double farMetres);

/// Pixel (u,v) (OpenCV convention) that a clip-space position lands on, after the perspective divide.
glm::dvec2 pixelFromClip(const glm::dvec4& clip, int width, int height);

} // namespace lightskin::render
