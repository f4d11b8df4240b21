#include <lightskin/core/Error.h>
#include <lightskin/gi/reference/RayTracedGroundTruth.h>
#include <lightskin/gi/common/TriangleRayScene.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <thread>
#include <vector>

namespace lightskin::gi {

struct RayTracedGroundTruth::Impl {
    TriangleRayScene scene;
};

RayTracedGroundTruth::RayTracedGroundTruth() = default;
RayTracedGroundTruth::~RayTracedGroundTruth() = default;
RayTracedGroundTruth::RayTracedGroundTruth(RayTracedGroundTruth&&) noexcept = default;
RayTracedGroundTruth& RayTracedGroundTruth::operator=(RayTracedGroundTruth&&) noexcept = default;

namespace {
// Orthonormal tangents of a unit normal (Duff et al. 2017, branchless).
void tangents(const glm::dvec3& n, glm::dvec3& t, glm::dvec3& b) {
    const double sign = std::copysign(1.0, n.z);
    const double a = -1.0 / (sign + n.z);
    const double c = n.x * n.y * a;
    t = {1.0 + sign * n.x * n.x * a, sign * c, -sign * n.x};
    b = {c, sign + n.y * n.y * a, -n.y};
}

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
} // namespace

RayTracedGroundTruth RayTracedGroundTruth::create(std::span<const GroundTruthMesh> meshes) {
    RayTracedGroundTruth out;
    out.impl_ = std::make_unique<Impl>();
    Impl& impl = *out.impl_;
    std::vector<RayMesh> rayMeshes;
    for (std::size_t m = 0; m < meshes.size(); ++m) {
        LIGHTSKIN_ASSERT(meshes[m].mesh != nullptr, "GroundTruthMesh without a mesh");
        meshes[m].mesh->validate("ground-truth mesh " + std::to_string(m));
        rayMeshes.push_back({meshes[m].mesh, meshes[m].world_T_model});
    }
    impl.scene = TriangleRayScene::create(rayMeshes, "ground truth", TriangleRayScene::BuildQuality::High);
    return out;
}

bool RayTracedGroundTruth::occluded(const glm::dvec3& from, const glm::dvec3& to, double rayEpsilon) const {
    LIGHTSKIN_ASSERT(impl_, "RayTracedGroundTruth used before create()");
    const glm::dvec3 d = to - from;
    const double length = glm::length(d);
    if (!(length > 0.0)) return false;
    // Unnormalised direction = the segment: t in [eps, 1 - eps] covers it independent of scale.
    return impl_->scene.occluded(from, d, rayEpsilon, 1.0 - rayEpsilon);
}

void RayTracedGroundTruth::compute(std::span<const VirtualAreaLight> vals,
                                   std::span<const GroundTruthReceiver> receivers, std::span<GroundTruthResult> out,
                                   const GroundTruthSettings& settings) const {
    LIGHTSKIN_ASSERT(impl_, "RayTracedGroundTruth used before create()");
    LIGHTSKIN_ASSERT(out.size() == receivers.size(), "one result per receiver");
    if (settings.discRings < 1 || settings.discSectors < 1 ||
        !(settings.rayEpsilon > 0.0 && settings.rayEpsilon < 0.5) ||
        !(settings.glossyC >= 0.0 && std::isfinite(settings.glossyC)))
        throw Error("GroundTruthSettings", std::nullopt,
                    "need rings, sectors >= 1, 0 < rayEpsilon < 0.5 and a finite glossyC >= 0");
    const bool centreMode = settings.discRings == 1 && settings.discSectors == 1;
    const int cells = settings.discRings * settings.discSectors;
    const double pi = std::numbers::pi;

    const auto evaluateRange = [&](std::size_t begin, std::size_t end) {
        for (std::size_t r = begin; r < end; ++r) {
            const GroundTruthReceiver& receiver = receivers[r];
            const glm::dvec3 x = receiver.position;
            const glm::dvec3 nx = glm::normalize(receiver.normal);
            const glm::dvec3 view = glm::normalize(receiver.toViewer);
            const glm::dvec3 rho(receiver.material.diffuseAlbedo), fs(receiver.material.specularAlbedo);
            const double k = double(receiver.material.specularExponent);
            const bool glossy = receiver.material.hasSpecular();
            glm::dvec3 irradiance(0.0), unoccluded(0.0), glossyRadiance(0.0);
            for (const VirtualAreaLight& val : vals) {
                if (!(val.area > 0.0f) || !std::isfinite(val.area) || !finite(val.position) || !finite(val.normal) ||
                    !finite(val.flux))
                    continue;
                const double area = double(val.area);
                const glm::dvec3 centre(val.position);
                const glm::dvec3 nl = glm::normalize(glm::dvec3(val.normal));
                const glm::dvec3 emitted = glm::dvec3(val.flux) / (pi * area); // L_e
                const double radius2 = area / pi;
                // Adds one quadrature point y: `geometric` = cos(theta_j) / d^2 * dA (or the centre's
                // disc form factor without cos(theta_i)), cosI = cos(theta_i) > 0.
                const auto add = [&](const glm::dvec3& y, double geometric, double cosI,
                                     const glm::dvec3& towardLight) {
                    if (!(geometric > 0.0)) return;
                    const glm::dvec3 incident = emitted * geometric; // L_e cos(theta_j) dA / d^2 ("M_j w_j")
                    unoccluded += incident * cosI;
                    if (settings.visibility && occluded(x, y, settings.rayEpsilon)) return;
                    irradiance += incident * cosI;
                    if (glossy) {
                        const glm::dvec3 mirror = 2.0 * glm::dot(towardLight, nx) * nx - towardLight;
                        const double cosGamma = std::max(0.0, glm::dot(mirror, view));
                        glossyRadiance +=
                            fs * incident * (settings.glossyC * (k + 1.0) * std::pow(cosGamma, k)); // eq. 5
                    }
                };
                if (centreMode) {
                    const glm::dvec3 toLight = centre - x;
                    const double d2 = glm::dot(toLight, toLight);
                    if (!(d2 > 0.0)) continue;
                    const glm::dvec3 w = toLight / std::sqrt(d2);
                    const double cosI = glm::dot(nx, w), cosJ = -glm::dot(nl, w);
                    if (cosI <= 0.0 || cosJ <= 0.0) continue;
                    add(centre, pi * radius2 * cosJ / (radius2 + d2), cosI, w); // pi * F_disk / cos(theta_i) (eq. 3)
                    continue;
                }
                glm::dvec3 t, b;
                tangents(nl, t, b);
                const double radius = std::sqrt(radius2);
                const double cellArea = area / double(cells);
                for (int ring = 0; ring < settings.discRings; ++ring) {
                    const double rho_r = radius * std::sqrt((ring + 0.5) / settings.discRings);
                    for (int sector = 0; sector < settings.discSectors; ++sector) {
                        const double phi = 2.0 * pi * (sector + 0.5) / settings.discSectors;
                        const glm::dvec3 y = centre + rho_r * (std::cos(phi) * t + std::sin(phi) * b);
                        const glm::dvec3 toLight = y - x;
                        const double d2 = glm::dot(toLight, toLight);
                        if (!(d2 > 0.0)) continue;
                        const glm::dvec3 w = toLight / std::sqrt(d2);
                        const double cosI = glm::dot(nx, w), cosJ = -glm::dot(nl, w);
                        if (cosI <= 0.0 || cosJ <= 0.0) continue;
                        add(y, cosJ / d2 * cellArea, cosI, w);
                    }
                }
            }
            out[r].irradiance = irradiance;
            out[r].unoccludedIrradiance = unoccluded;
            out[r].radiance = rho / pi * irradiance + glossyRadiance;
        }
    };
    // Receivers are independent and rtcOccluded1 is thread-safe: contiguous chunks per thread.
    const std::size_t threadCount = std::clamp<std::size_t>(
        settings.threads > 0 ? std::size_t(settings.threads) : std::max(1u, std::thread::hardware_concurrency()), 1,
        std::max<std::size_t>(1, receivers.size()));
    if (threadCount == 1) {
        evaluateRange(0, receivers.size());
        return;
    }
    std::vector<std::thread> workers;
    const std::size_t chunk = (receivers.size() + threadCount - 1) / threadCount;
    for (std::size_t t = 0; t < threadCount; ++t) {
        const std::size_t begin = t * chunk, end = std::min(receivers.size(), begin + chunk);
        if (begin < end) workers.emplace_back(evaluateRange, begin, end);
    }
    for (std::thread& worker : workers) worker.join();
}

} // namespace lightskin::gi
