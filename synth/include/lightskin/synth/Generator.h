#pragma once
// Frames of a synthetic recording: rendered view -> RgbdFrame (sRGB colour, 16-bit depth with
// the scene's scale, intrinsics, exact world_T_camera) plus the exact float channels.
// Needs a current OpenGL 4.5 core context while it lives (see SceneRenderer).

#include <lightskin/core/RgbdFrame.h>
#include <lightskin/synth/SceneDescription.h>
#include <lightskin/synth/SceneRenderer.h>

#include <filesystem>
#include <vector>

namespace lightskin::synth {

struct SynthFrame {
    /// Colour (CV_8UC3 BGR, sRGB of exposure * radiance), depth (CV_16UC1, scene.depthScaleMetres,
    /// 0 = missing, noisy when the scene's noise is enabled), intrinsics (colour = depth,
    /// registered), timestamps index / fps, groundTruth_world_T_camera exact.
    RgbdFrame frame;
    RenderedView exact;         ///< exact radiance, depth, normals, positions of this view
    cv::Mat noisyDepthMetres;   ///< CV_32FC1 depth after the noise model, before 16-bit quantisation
};

/// 8-bit sRGB of linear value x (IEC 61966-2-1), x clamped to [0, 1], rounded to nearest.
std::uint8_t encodeSrgb(float linear) noexcept;
/// Inverse of the sRGB transfer function for an 8-bit value, linear in [0, 1].
float decodeSrgb(std::uint8_t encoded) noexcept;

class Generator {
public:
    /// Builds the renderer (current context needed). Throws lightskin::Error on a bad scene.
    static Generator create(const SceneDescription& scene, const TagBitmapSource& tags = apriltagBitmaps());

    const SceneDescription& scene() const noexcept { return scene_; }
    int frameCount() const noexcept { return scene_.path.frameCount(); }

    /// Renders frame `index` (0 <= index < frameCount()) into `out`, reusing its buffers.
    void renderFrameInto(int index, SynthFrame& out);
    /// Every frame, deep copies (for tests and small scenes).
    std::vector<SynthFrame> renderAll();

private:
    SceneDescription scene_;
    SceneRenderer renderer_;
    cv::Mat cameraNormals_, noiseScratch_;
};

/// Converts exact, noise-free or noisy depth in metres to 16-bit units (rounded; 0 stays 0;
/// values beyond 65535 units become 0 = missing).
void depthMetresToUnitsInto(const cv::Mat& metres, double scaleMetres, cv::Mat& units);

} // namespace lightskin::synth
