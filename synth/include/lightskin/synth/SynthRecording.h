#pragma once
// Writes a synthetic scene as a lightskin recording (capture/Recording.h, recordings/README.md: sRGB colour,
// 16-bit depth, intrinsics, exact groundTruth_world_T_camera per frame) with its exact extras in <folder>/synth/
// (the scene description, ground truth and tags, optional float normals/positions/radiance TIFFs and
// present-object frames). The files and their formats: docs/SYNTH.md, "Output layout".
// Needs a current OpenGL 4.5 core context.

#include <lightskin/synth/PresentObjects.h>
#include <lightskin/synth/SceneDescription.h>
#include <lightskin/synth/SceneRenderer.h>

#include <cstdint>
#include <filesystem>
#include <functional>

namespace lightskin::synth {

struct SynthRecordingOptions {
    /// Write at most this many frames (0 = all).
    int maxFrames = 0;
    /// Called after each frame with (frames written, total).
    std::function<void(int, int)> progress;
    /// Asked before each frame: true stops there and finishes the recording with the frames written.
    std::function<bool()> stopRequested;
    /// A lightskin scene file: also write synth/present/ with its objects really in the room.
    std::filesystem::path presentObjects;
};

/// Renders every frame of `scene` and writes it to `folder`, which must not exist or be empty.
/// `sceneText` is stored as synth/scene.json (the description as written by its author).
/// Returns the number of frames written. Throws lightskin::Error (folder, frame, cause).
std::int64_t writeSynthRecording(const SceneDescription& scene, const std::string& sceneText,
                                 const std::filesystem::path& folder, const SynthRecordingOptions& options = {},
                                 const TagBitmapSource& tags = apriltagBitmaps());

/// Reads a float channel image written by writeSynthRecording (CV_32FC3). Throws lightskin::Error.
cv::Mat readSynthChannel(const std::filesystem::path& file);

} // namespace lightskin::synth
