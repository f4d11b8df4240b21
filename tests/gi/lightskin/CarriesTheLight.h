#pragma once
// "The technique delivers the light": tests that compare two runs (reuse against recomputation,
// two fresh techniques, culled against unculled) would pass on two all-zero images. This check
// sums the image over every `step`-th covered pixel and compares it with the double brute force
// (eq. 2: every VAL at every pixel, no visibility) at the same pixels, from the rig's G-buffer
// (position, normal, material: the G-buffer carries rho_d, f_s and k, so no instance lookup).
//
// The bound 1/2, derived: LightSkin's interpolation error against the brute force is a few percent
// on these smooth scenes (BruteForceGLTest.LightSkinIsCloseToBruteForceOnASmoothScene: 3 %;
// gi_truth_gl_test: < 1 %), and occlusion only removes light that geometry blocks, at most 30 %
// here (a sphere over a floor: the Embree truth measures 12 % blocked on the similar convex scene of
// gi_truth_gl_test; one convex object blocks nothing). So a working technique delivers >= 0.7 of
// the brute force; 0.5 leaves a factor 1.4 of margin and still fails a GI that outputs zeros, drops
// the diffuse channel (the diffuse part is > 60 % of every scene's light) or halves the light.
// Needs a current GL context; the rig's G-buffer must hold the frame `image` was rendered from.
#include "common/GpuRig.h"

#include <lightskin/gi/reference/LightSkinReference.h>
#include <lightskin/gi/common/VirtualAreaLight.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <span>
#include <string>
#include <vector>

namespace lightskin::test {

/// Fraction of the brute force's light a working technique delivers at least (derivation above).
inline constexpr double kMinShareOfBruteForce = 0.5;

inline std::vector<glm::vec4> readGBufferTexels(std::uint32_t texture, int width, int height) {
    std::vector<glm::vec4> texels(std::size_t(width) * std::size_t(height));
    glGetTextureImage(texture, 0, GL_RGBA, GL_FLOAT, GLsizei(texels.size() * sizeof(glm::vec4)), texels.data());
    return texels;
}

/// Asserts that `image` (RGBA32F, rig.width x rig.height) carries at least kMinShareOfBruteForce of
/// the double brute force's light over every `step`-th covered pixel; `glossy` as the technique ran.
inline void expectCarriesTheLight(const GpuRig& rig, const std::vector<glm::vec4>& image,
                                  std::span<const gi::VirtualAreaLight> vals, bool glossy, const std::string& what,
                                  std::size_t step = 5) {
    const gi::GBufferView g = rig.gbuffer.view();
    const auto position = readGBufferTexels(g.worldPosition, rig.width, rig.height);
    const auto normal = readGBufferTexels(g.worldNormal, rig.width, rig.height);
    const auto albedo = readGBufferTexels(g.diffuseAlbedo, rig.width, rig.height);
    const auto specular = readGBufferTexels(g.specular, rig.width, rig.height);
    ASSERT_EQ(image.size(), position.size()) << what;
    gi::reference::GatherParameters parameters;
    parameters.glossy = glossy;
    double delivered = 0.0, brute = 0.0;
    std::size_t covered = 0;
    for (std::size_t i = 0; i < image.size(); ++i) {
        if (position[i].w == 0.0f || covered++ % step != 0) continue;
        const gi::reference::Surface s{glm::dvec3(position[i]), glm::normalize(glm::dvec3(normal[i])),
                                       glm::dvec3(albedo[i]), glm::dvec3(specular[i]),
                                       std::max(1.0, double(specular[i].w))};
        const glm::dvec3 expected = gi::reference::bruteForce(vals, s, glm::dvec3(rig.eye), parameters);
        delivered += double(image[i].x) + double(image[i].y) + double(image[i].z);
        brute += expected.x + expected.y + expected.z;
    }
    ASSERT_GE(covered / step, 10u) << what << ": too few covered pixels to sum";
    ASSERT_GT(brute, 0.0) << what << ": the scene must be lit";
    EXPECT_GT(delivered, kMinShareOfBruteForce * brute)
        << what << ": the technique must deliver the light (" << delivered / brute << " of the brute force's)";
}

} // namespace lightskin::test
