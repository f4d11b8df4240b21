#pragma once
// Headless rendering of a SceneDescription on the GL layer: exact radiance, depth, normals and
// positions for one camera pose. Needs a current OpenGL 4.5 core context for its whole life
// (gl::createHeadlessContext()); destroy it before the context.
//
// Radiometry (docs/SYNTH.md): every surface is Lambertian with albedo rho; outgoing radiance
//   L = rho / pi * sum over light samples [ I(omega) * max(0, n . l) / d^2 * V ] + rho * L_ambient + L_e
// with I = P / (4 pi) for a point light and I = P / (pi N^2) * cos(theta_light) for each of the
// N x N midpoint samples of a Lambertian area light of power P; V is 0 or 1 from an exact
// shadow ray against the scene's boxes (the room is convex and tags are flat, so nothing else
// can occlude a light inside the room). The area light's own panel is drawn with radiance
// L_e = P / (pi A) on its front face. No interreflection: the radiance is direct light only (plus
// the optional ambient term), which is what makes it exact.

#include <lightskin/core/Pose.h>
#include <lightskin/gl/Objects.h>
#include <lightskin/synth/SceneDescription.h>

#include <opencv2/core/mat.hpp>

#include <functional>
#include <memory>
#include <string>

namespace lightskin::synth {

/// An AprilTag's pattern, one pixel per cell (CV_8UC1, 0 = black, 255 = white, top row first),
/// including the white border cells; the square that defines the tag size (tracking::TagLayout)
/// starts at cell (borderStartCell, borderStartCell) and is borderCells cells wide.
struct TagBitmap {
    cv::Mat cells;
    int borderStartCell = 0;
    int borderCells = 0;
};

/// Gives the bitmap of tag `id` of `family`; throws lightskin::Error for an unknown family or id.
using TagBitmapSource = std::function<TagBitmap(const std::string& family, int id)>;

/// The tag bitmaps of Debian's libapriltag through lightskin::tracking (renderTagBitmap).
TagBitmapSource apriltagBitmaps();

/// Images of one view. Pixel (u,v) is the pixel centre in OpenCV's convention. Pixels that see
/// no surface (impossible inside the closed room) hold 0.
struct RenderedView {
    cv::Mat radiance;      ///< CV_32FC3 linear radiance W m^-2 sr^-1, BGR order (like RgbdFrame::colour), mean of the supersampling^2 samples over the pixel
    cv::Mat depthMetres;   ///< CV_32FC1 z along the optical axis at the pixel centre, metres
    cv::Mat worldNormal;   ///< CV_32FC3 unit surface normal (x, y, z), world frame, at the pixel centre
    cv::Mat worldPosition; ///< CV_32FC3 surface point (x, y, z), world metres, at the pixel centre
};

class SceneRenderer {
public:
    SceneRenderer();
    ~SceneRenderer();
    SceneRenderer(SceneRenderer&&) noexcept;
    SceneRenderer& operator=(SceneRenderer&&) noexcept;

    /// Builds geometry, tag textures and shaders. Throws lightskin::Error on a bad scene (too
    /// many light samples, unknown tag) or a GL failure.
    static SceneRenderer create(const SceneDescription& scene, const TagBitmapSource& tags);

    /// Renders the view of a camera at world_T_camera with the scene's intrinsics into `out`
    /// (buffers reused when their sizes match).
    void renderInto(const Pose& world_T_camera, RenderedView& out);

    /// The black-border corners of tag `index` (scene.tags order) in world coordinates, in the
    /// order top-left, top-right, bottom-right, bottom-left as seen from the front.
    static std::array<glm::dvec3, 4> tagCornersWorld(const TagDescription& tag);

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// OpenGL clip-from-camera matrix for OpenCV intrinsics (camera x right, y down, z forward):
/// pixel (u,v) centres land on GL fragment centres, with image row 0 at the top after a
/// vertical flip of the read-back image. Column-major (glm).
glm::dmat4 projectionFromIntrinsics(const CameraIntrinsics& intrinsics, double nearMetres, double farMetres);

} // namespace lightskin::synth
