#include "GatherTestScenes.h"

#include <glm/geometric.hpp>

#include <cmath>
#include <numbers>
#include <random>

namespace lightskin::test {

TriangleMesh makeSphere(float radius, int stacks, int slices) {
    TriangleMesh mesh;
    const float pi = std::numbers::pi_v<float>;
    for (int i = 0; i <= stacks; ++i) {
        const float theta = pi * float(i) / float(stacks);
        for (int j = 0; j <= slices; ++j) {
            const float phi = 2.0f * pi * float(j) / float(slices);
            const glm::vec3 n(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
            mesh.positions.push_back(radius * n);
            mesh.normals.push_back(n);
        }
    }
    const auto at = [&](int i, int j) { return std::uint32_t(i * (slices + 1) + j); };
    for (int i = 0; i < stacks; ++i)
        for (int j = 0; j < slices; ++j) {
            mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1)});
            mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
    return mesh;
}

TriangleMesh makeGrid(float size, int cells) {
    TriangleMesh mesh;
    for (int i = 0; i <= cells; ++i)
        for (int j = 0; j <= cells; ++j) {
            mesh.positions.emplace_back(size * (float(j) / float(cells) - 0.5f), size * (float(i) / float(cells) - 0.5f), 0.0f);
            mesh.normals.emplace_back(0.0f, 0.0f, 1.0f);
        }
    const auto at = [&](int i, int j) { return std::uint32_t(i * (cells + 1) + j); };
    for (int i = 0; i < cells; ++i)
        for (int j = 0; j < cells; ++j) {
            mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i, j + 1), at(i + 1, j + 1)});
            mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j + 1), at(i + 1, j)});
        }
    return mesh;
}

std::vector<gi::VirtualAreaLight> squareEmitter(const glm::vec3& centre, const glm::vec3& normal, float size,
                                                int resolution, const glm::vec3& radiance) {
    const glm::vec3 n = glm::normalize(normal);
    const glm::vec3 helper = std::abs(n.z) < 0.9f ? glm::vec3(0, 0, 1) : glm::vec3(1, 0, 0);
    const glm::vec3 t = glm::normalize(glm::cross(helper, n));
    const glm::vec3 b = glm::cross(n, t);
    const float cell = size / float(resolution);
    std::vector<gi::VirtualAreaLight> vals;
    vals.reserve(std::size_t(resolution) * std::size_t(resolution));
    for (int i = 0; i < resolution; ++i)
        for (int j = 0; j < resolution; ++j) {
            const glm::vec3 p = centre + t * ((float(j) + 0.5f) * cell - 0.5f * size) + b * ((float(i) + 0.5f) * cell - 0.5f * size);
            vals.push_back(disc(p, n, cell * cell, std::numbers::pi_v<float> * radiance * cell * cell));
        }
    return vals;
}

gi::VirtualAreaLight disc(const glm::vec3& position, const glm::vec3& normal, float area, const glm::vec3& flux) {
    gi::VirtualAreaLight l;
    l.position = position;
    l.normal = glm::normalize(normal);
    l.area = area;
    l.flux = flux;
    return l;
}

std::vector<gi::VirtualAreaLight> randomVals(std::size_t count, const glm::vec3& lo, const glm::vec3& hi,
                                             const glm::vec3& target, float area, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<gi::VirtualAreaLight> vals;
    vals.reserve(count);
    for (std::size_t i = 0; i < count; ++i) {
        const glm::vec3 p = lo + (hi - lo) * glm::vec3(u(rng), u(rng), u(rng));
        const glm::vec3 flux(0.2f + u(rng), 0.2f + u(rng), 0.2f + u(rng));
        vals.push_back(disc(p, target - p, area, flux * area));
    }
    return vals;
}

} // namespace lightskin::test
