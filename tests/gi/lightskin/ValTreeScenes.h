#pragma once
// Scenes of the VAL tree tests (ValTreeTest.cpp, ValTreeGpuBuildGLTest.cpp): VAL sets with receivers,
// chosen for the tree's hard cases (contact, normals on both sides, a flux range of 12 orders), and the
// pixel keys an image would give them (for the image quadtree).
#include <lightskin/gi/reference/LightSkinReference.h>
#include <lightskin/gi/lightskin/ValTree.h>
#include <lightskin/gi/common/VirtualAreaLight.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace lightskin::test {

// Receivers: the sparse points of a sphere of radius 0.3 m at `centre`, outward normals, Phong k = 20.
std::vector<gi::reference::Receiver> sphereReceivers(const glm::vec3& centre, int stacks, int slices);

struct ValTreeScene {
    std::string name;
    std::vector<gi::VirtualAreaLight> vals;
    std::vector<gi::reference::Receiver> receivers;
};
ValTreeScene roomScene();                  ///< 3 x 64^2 VALs of a room around a sphere
ValTreeScene cloudScene();                 ///< 8000 pseudo-random VALs facing the sphere (a noisy depth cloud)
ValTreeScene contactScene();               ///< VALs 1 mm above a receiving plane
ValTreeScene bothSidesScene();             ///< VALs on both sides of the receivers, normals in every direction
ValTreeScene fluxRangeScene();             ///< flux over 12 orders of magnitude
std::vector<ValTreeScene> valTreeScenes(); ///< all of the above

/// The eye of the glossy lobe in these scenes, world metres.
inline const glm::dvec3 kValTreeEye(0.5, -2.0, 1.0);

/// Pixel keys for a scene's VALs (ValSetView::keys), see ValTreeScenes.cpp.
struct ImageKeys {
    std::vector<std::uint32_t> keys;
    std::uint32_t width = 0, height = 0;
};
ImageKeys imageKeys(const std::vector<gi::VirtualAreaLight>& vals);

/// A float tree (e.g. GpuValQuadtree's nodes read back) as a double tree for the reference walk: the
/// same numbers, widened.
gi::ValTreeD widenValTree(const std::vector<gi::ValCluster>& nodes);

} // namespace lightskin::test
