#pragma once
// Writes a synthetic scene as a lightskin recording (capture/Recording.h, recordings/README.md)
// with its exact extras beside it:
//
//   <folder>/lightskin-recording.json, frames.jsonl, colour/, depth/   the recording (capture's
//        format): sRGB colour, 16-bit depth, intrinsics, exact groundTruth_world_T_camera per frame
//   <folder>/synth/scene.json              the scene description it was made from (regenerate with
//                                          `lightskin synth <folder>/synth/scene.json --out <new>`)
//   <folder>/synth/ground-truth.json       exposure, depth scale, noise switch, the tags (family,
//                                          id, size, world_T_tag, black-border corners in the world)
//   <folder>/synth/tag-world.json          the tags as a tracking world (tracking/TagWorld.h format)
//   <folder>/synth/normals/000000.tiff     optional, per frame: CV_32FC3 float TIFF (deflate,
//   <folder>/synth/positions/000000.tiff   lossless), exact world normals / world positions (x,y,z
//   <folder>/synth/radiance/000000.tiff    in channels 0,1,2), linear radiance (B,G,R) before exposure
//   <folder>/synth/present/000000.png      optional (SynthRecordingOptions::presentObjects): the frame
//                                          with a lightskin scene's virtual objects really in the room
//                                          (PresentObjects.h), encoded like colour/; the ground truth
//                                          of a differential composite (`lightskin replay` compares)
//
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
