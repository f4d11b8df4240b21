#pragma once
// Analytic scenes for the gather tests: meshes (sphere, plane grid) and VAL sets (uniform
// emitting squares discretised into discs, single discs).
#include <lightskin/core/TriangleMesh.h>
#include <lightskin/gi/common/VirtualAreaLight.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <vector>

namespace lightskin::test {

TriangleMesh makeSphere(float radius, int stacks, int slices);
/// A square of side `size` in the plane z = 0 (normal +z), `cells` x `cells` quads.
TriangleMesh makeGrid(float size, int cells);

/// A square emitter of side `size` centred at `centre`, facing `normal`, of uniform radiance
/// `radiance`, discretised into resolution x resolution disc VALs (area = cell area,
/// flux = pi * radiance * area).
std::vector<gi::VirtualAreaLight> squareEmitter(const glm::vec3& centre, const glm::vec3& normal, float size,
                                                int resolution, const glm::vec3& radiance);
gi::VirtualAreaLight disc(const glm::vec3& position, const glm::vec3& normal, float area, const glm::vec3& flux);
/// Deterministic pseudo-random VALs in a box, normals toward `target`.
std::vector<gi::VirtualAreaLight> randomVals(std::size_t count, const glm::vec3& lo, const glm::vec3& hi,
                                             const glm::vec3& target, float area, std::uint32_t seed);

} // namespace lightskin::test
