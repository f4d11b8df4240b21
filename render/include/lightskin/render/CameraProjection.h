#pragma once
// The colour camera as an OpenGL projection.
//
// Camera frame: OpenCV (x right, y down, z forward along the optical axis, metres). Pixel (u,v):
// OpenCV convention, (0,0) the centre of the top-left pixel, v downwards. The renderer draws into
// GL framebuffers whose row 0 is the *bottom* row; images read back with gl::Readback are flipped
// so that row 0 is the top row, i.e. image row v = H-1-(GL window row).
//
// clip_T_camera maps an OpenCV camera-frame point (X,Y,Z) straight to GL clip space:
//   x_c = (2 fx / W) X + ((2 cx + 1) / W - 1) Z
//   y_c = -(2 fy / H) Y + (1 - (2 cy + 1) / H) Z
//   z_c = (f + n) / (f - n) Z - 2 f n / (f - n)
//   w_c = Z
// so that NDC x = (2u + 1)/W - 1 and NDC y = 1 - (2v + 1)/H for u = fx X/Z + cx, v = fy Y/Z + cy:
// GL window x = u + 0.5 and window y = H - (v + 0.5), i.e. pixel centres land on pixel centres.
// Depth: Z = n maps to NDC -1 and Z = f to +1. The change of axes from OpenCV to GL's eye frame
// (diag(1,-1,-1)) is a rotation, so counter-clockwise front faces stay counter-clockwise.
// Distortion is not part of the projection: the compositor warps the rendered layers instead.

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>

#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace lightskin::render {

/// `nearMetres` > 0, `farMetres` > `nearMetres`; intrinsics must be valid (fy may be negative).
glm::dmat4 clipFromCamera(const CameraIntrinsics& intrinsics, double nearMetres, double farMetres);

/// clip_T_world = clipFromCamera * camera_T_world, with camera_T_world = inverse(world_T_camera).
glm::dmat4 clipFromWorld(const CameraIntrinsics& intrinsics, const Pose& world_T_camera, double nearMetres, double farMetres);

/// Pixel (u,v) (OpenCV convention) that a clip-space position lands on, after the perspective divide.
glm::dvec2 pixelFromClip(const glm::dvec4& clip, int width, int height);

} // namespace lightskin::render
