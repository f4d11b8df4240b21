#pragma once
// The synthetic mixed-reality scenes of the benchmarks: an analytic room seen by a Kinect-like depth
// camera (so ValGenerator makes VALs exactly as from a captured frame) with virtual objects on its floor,
// and the gather benchmarks' sphere over a floor. World frame: metres, Z up (Blender's convention, for
// scripts/blender_reference.py); camera frames OpenCV (x right, y down, z forward). The room's layout and
// why it looks like this: docs/BENCHMARKS.md, "Speed against accuracy: method".
#include <lightskin/bench/OptionLists.h>
#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Material.h>
#include <lightskin/core/Pose.h>
#include <lightskin/core/TriangleMesh.h>
#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gi/common/VirtualAreaLight.h>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <opencv2/core/mat.hpp>

#include <algorithm>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace lightskin::bench {

/// The paper-style Kinect intrinsics (525 px, 640x480) of the synthetic depth camera.
CameraIntrinsics depthIntrinsics();

/// world_T_camera of a camera at `eye` looking at `target` (Z up), OpenCV axes.
Pose lookAtPose(const glm::dvec3& eye, const glm::dvec3& target);

/// The default depth-camera pose; `shift` moves it along world x (metres) for the depth-edge sequence.
Pose depthCameraPose(double shift = 0.0);

/// Renders the room into depth (CV_32FC1, metres along the optical axis) and colour (CV_8UC3, BGR,
/// sRGB-encoded). A bright "spot" (a lit patch, sRGB 255) of radius 0.3 m sits on the back wall
/// (y = 2.2) at x = spotX, z = 1.3: moving it is the moving-light sequence.
void renderRoom(const CameraIntrinsics& K, const Pose& world_T_camera, double spotX, cv::Mat& depth,
                cv::Mat& colourBgr);

/// A UV sphere of `radius` with about `triangles` triangles (stacks x 2 stacks grid), normals set.
TriangleMesh uvSphere(float radius, std::size_t triangles);

/// The Stanford bunny (tests/data/stanford-bunny/bun_zipper_res4.ply, found from `sourceDir`),
/// rotated to Z up, 0.45 m tall, standing on z = 0 at the origin, refined to ~15k triangles.
/// Throws lightskin::Error when the file is missing or malformed.
TriangleMesh bunny(const std::string& sourceDir);

/// Placement and materials of the two virtual objects.
glm::mat4 sphereWorld();
glm::mat4 bunnyWorld();
Material sphereMaterial();
Material bunnyMaterial();

/// The view camera of the composited image (static frames), and its path for the moving-camera
/// sequence (frame t of n; t = 0 is the static view).
glm::vec3 viewEye(int t = 0, int n = 1);
glm::vec3 viewTarget();
glm::mat4 viewClip(int width, int height, int t = 0, int n = 1);

// ---- the GI gather benchmarks' scene (bench-gather, bench-cpu) ----
/// A square of side `size` (metres) in the plane z = 0, normal +z, cells x cells quads.
TriangleMesh grid(float size, int cells);
/// A width x height VAL map like a depth camera's: half on a wall (x = -1.2, facing +x), half on
/// the ceiling (z = 1.8, facing down), radiance 0.5 x a smooth colour pattern.
std::vector<gi::VirtualAreaLight> valMap(int width, int height);
/// A --vals entry "WIDTHxHEIGHT" (width > 0, height > 1); throws lightskin::Error naming --vals otherwise.
std::pair<int, int> parseValMapSize(const std::string& text);

/// The gather benchmarks' scene: a glossy sphere (0.4 m, ~16k triangles) 0.55 m above a 2.4 m
/// floor of 64 x 64 cells, seen from (1.8, -2.0, 1.6), with its G-buffer rendered at width x
/// height. Needs a current GL context; `instances` point into `meshes` (kept valid by moves).
struct GatherScene {
    std::vector<TriangleMesh> meshes;
    std::vector<gi::UploadedMesh> gpu;
    std::vector<gi::MeshInstance> instances;
    gi::ViewParameters view;
    gi::SimpleGBuffer gbuffer;
};
GatherScene gatherScene(int width, int height);

} // namespace lightskin::bench
