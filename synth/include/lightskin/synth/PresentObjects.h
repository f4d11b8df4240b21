#pragma once
// "The virtual objects really there": the ground truth a differential composite is
// compared with. Recomputes each frame of the synthetic room as if a lightskin scene's virtual
// objects stood in it, in the room's own one-bounce model (Embree visibility against the objects).
// The formulas for room and object pixels and what is not modelled: docs/SYNTH.md, "Objects present".
//
// Frames: world metres, z up (SceneDescription). Needs a current GL 4.5 context in create() only.

#include <lightskin/core/Material.h>
#include <lightskin/core/Pose.h>
#include <lightskin/core/TriangleMesh.h>
#include <lightskin/synth/SceneDescription.h>
#include <lightskin/synth/SceneRenderer.h>

#include <opencv2/core/mat.hpp>

#include <filesystem>
#include <memory>
#include <vector>

namespace lightskin::synth {

struct PresentObject {
    std::string name;
    TriangleMesh mesh; ///< world frame, metres (placed), unit vertex normals
    Material material; ///< diffuse albedo, Phong specular; textures are ignored
};

struct PresentObjectsSettings {
    int emittersPerObject = 256; ///< >= 1
    int roomCubeSize = 16;       ///< >= 2: texels per side of each cube-map face of the room
};

/// The objects of a lightskin scene file (render/Scene.h: meshes, transforms, material overrides),
/// placed in the world. Throws lightskin::Error naming the file, object or mesh.
std::vector<PresentObject> loadPresentObjects(const std::filesystem::path& lightskinScene);

class PresentObjects {
public:
    PresentObjects();
    ~PresentObjects();
    PresentObjects(PresentObjects&&) noexcept;
    PresentObjects& operator=(PresentObjects&&) noexcept;

    /// Builds the occluders and renders the room's cube maps (current GL context needed). Throws
    /// lightskin::Error on bad settings, an empty object list or Embree errors.
    static PresentObjects create(const SceneDescription& room, std::vector<PresentObject> objects,
                                 const TagBitmapSource& tags, const PresentObjectsSettings& settings = {});

    /// The view of the camera at world_T_camera (scene intrinsics) with the objects present, from
    /// the room's exact view: `out` CV_32FC3 BGR linear radiance (reallocated when the size changes).
    void renderInto(const Pose& world_T_camera, const RenderedView& room, cv::Mat& out) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace lightskin::synth
