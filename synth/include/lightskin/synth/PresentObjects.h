#pragma once
// "The virtual objects really there" (issue 13): the ground truth a differential composite is
// compared with. Given the synthetic room (SceneDescription, rendered exactly by SceneRenderer:
// direct light + ambient, no interreflection) and a lightskin scene's virtual objects placed in
// the room, recomputes each frame's radiance as if the objects stood in the room, in the same
// one-bounce model (docs/SYNTH.md, "Objects present"):
//
//  * room pixel x (the camera ray meets the room before any object), albedo rho(x) unknown but
//    cancelling, L(x) = rho/pi (E(x) + pi L_a) from the exact render:
//      L_present(x) = L(x) (E_o(x) + pi L_a) / (E(x) + pi L_a) + rho(x)/pi E_b(x),
//    E = sum over the room's light samples of I cos/d^2 with exact box visibility (as the
//    renderer), E_o the same with the objects as occluders too (Embree rays), E_b the light the
//    objects reflect onto x: emitter discs on the objects (area-weighted, emittersPerObject each)
//    with flux rho_d (direct light with exact visibility + the room's one bounce) A, cosines only
//    between emitter and x (exact for convex objects); rho/pi = L / (E + pi L_a);
//  * object pixel y (the ray meets an object first; smooth vertex normals):
//      L_present(y) = rho_d/pi (E_o(y) + E_room(y)) + rho_d L_a + sum_l f_s (k+2)/(2 pi) cos^k(gamma) E_o,l(y),
//    E_room = the room's one bounce: the room rendered exactly into a cube map (roomCubeSize^2
//    texels per face) from each object's bounding-sphere centre, every texel a disc of its
//    radiance and true area, with Embree visibility against the objects from y.
// Not modelled: the objects blocking ambient light, bounces between objects, light from the
// objects' specular reflection onto the room. One sample per pixel centre (the room's own image
// keeps its supersampling where no object changes it).
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
