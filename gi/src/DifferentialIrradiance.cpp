#include <lightskin/core/Error.h>
#include <lightskin/gi/DifferentialIrradiance.h>
#include <lightskin/gi/TriangleRayScene.h>

#include <epoxy/gl.h>
#include <glm/geometric.hpp>
#include <opencv2/core.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

namespace lightskin::gi {

namespace {

struct BoundingSphere {
    glm::dvec3 centre{0.0};
    double radius = 0.0;
    double regionRadius = 0.0; ///< R_o (header: falloff)
};

/// The closed segment a-b passes within r of c.
bool segmentNearSphere(const glm::dvec3& a, const glm::dvec3& b, const BoundingSphere& s) {
    const glm::dvec3 d = b - a;
    const double length2 = glm::dot(d, d);
    const double t = length2 > 0.0 ? std::clamp(glm::dot(s.centre - a, d) / length2, 0.0, 1.0) : 0.0;
    const glm::dvec3 nearest = a + t * d - s.centre;
    return glm::dot(nearest, nearest) <= s.radius * s.radius;
}

/// Van der Corput radical inverse in base 2 (the second coordinate of a Hammersley set).
double radicalInverse2(std::uint32_t bits) {
    bits = (bits << 16u) | (bits >> 16u);
    bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
    bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
    bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
    bits = ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
    return double(bits) * 2.3283064365386963e-10;
}

glm::dvec3 toDouble(const glm::vec3& v) { return glm::dvec3(v); }

/// Direct irradiance I cone cos / d^2 of a light at (x, n), without visibility; 0 behind.
glm::dvec3 lightIrradiance(const glm::dvec3& x, const glm::dvec3& n, const VirtualLight& light) {
    const glm::dvec3 offset = toDouble(light.position) - x;
    const double d2 = glm::dot(offset, offset);
    if (!(d2 > 0.0)) return glm::dvec3(0.0);
    const glm::dvec3 l = offset / std::sqrt(d2);
    const double cosTheta = glm::dot(n, l);
    if (!(cosTheta > 0.0)) return glm::dvec3(0.0);
    if (light.type == VirtualLight::Type::Spot &&
        glm::dot(-l, glm::normalize(toDouble(light.direction))) < std::cos(double(light.spotHalfAngle)))
        return glm::dvec3(0.0);
    return toDouble(light.intensity) * (cosTheta / d2);
}

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

/// Discs (VALs or emitters) as structure-of-arrays floats for the vectorised gather below
/// (this file is compiled with -O3 and relaxed float associativity, gi/CMakeLists.txt).
struct DiscArrays {
    std::vector<float> px, py, pz, nx, ny, nz, r2, fr, fg, fb;
    void assign(std::span<const VirtualAreaLight> discs) {
        for (auto* v : {&px, &py, &pz, &nx, &ny, &nz, &r2, &fr, &fg, &fb}) v->resize(discs.size()); // keeps capacity
        for (std::size_t j = 0; j < discs.size(); ++j) {
            const VirtualAreaLight& d = discs[j];
            // An invalid disc (area <= 0 or non-finite data) adds exactly 0, as in ls_irradiance.
            const bool valid =
                d.area > 0.0f && std::isfinite(d.area) && finite(d.position) && finite(d.normal) && finite(d.flux);
            px[j] = valid ? d.position.x : 0.0f;
            py[j] = valid ? d.position.y : 0.0f;
            pz[j] = valid ? d.position.z : 0.0f;
            nx[j] = valid ? d.normal.x : 0.0f;
            ny[j] = valid ? d.normal.y : 0.0f;
            nz[j] = valid ? d.normal.z : 0.0f;
            r2[j] = valid ? d.area / float(std::numbers::pi) : 0.0f;
            fr[j] = valid ? d.flux.x : 0.0f;
            fg[j] = valid ? d.flux.y : 0.0f;
            fb[j] = valid ? d.flux.z : 0.0f;
        }
    }
    std::size_t size() const noexcept { return px.size(); }
};

/// Sum over discs of E_j = flux_j w_j at (x, n), w_j = cos(theta_j) cos(theta_i) / (pi (r_j^2 + d_j^2))
/// with the guards G1/G2 of gi/shaders/lightskin_math.glsl (ls_irradiance, in float); writes w_j.
glm::dvec3 gatherDiscs(const DiscArrays& d, const glm::dvec3& xd, const glm::dvec3& nd, float* weights) {
    const float x = float(xd.x), y = float(xd.y), z = float(xd.z), nx = float(nd.x), ny = float(nd.y), nz = float(nd.z);
    const float invPi = float(1.0 / std::numbers::pi);
    float sr = 0.0f, sg = 0.0f, sb = 0.0f;
    const std::size_t count = d.size();
    for (std::size_t j = 0; j < count; ++j) {
        const float dx = d.px[j] - x, dy = d.py[j] - y, dz = d.pz[j] - z;
        const float d2 = dx * dx + dy * dy + dz * dz;
        const float inv = 1.0f / std::sqrt(std::max(d2 + 1.0e-12f * d.r2[j], 1.0e-36f)); // G1
        const float cosI = std::max((nx * dx + ny * dy + nz * dz) * inv, 0.0f);
        const float cosJ = std::max(-(d.nx[j] * dx + d.ny[j] * dy + d.nz[j] * dz) * inv, 0.0f);
        const float w = cosJ / std::max(d.r2[j] + d2, 1.0e-36f) * cosI * invPi; // G2
        weights[j] = w;
        sr += d.fr[j] * w;
        sg += d.fg[j] * w;
        sb += d.fb[j] * w;
    }
    return {double(sr), double(sg), double(sb)};
}

/// candidates[j] = 1 where w_j > 0 and the segment from x to disc j passes within the sphere, else
/// left as it was (callers clear it first).
void markNearSphere(const DiscArrays& d, const glm::dvec3& xd, const glm::dvec3& centre, double radius,
                    const float* weights, float* candidates) {
    const float x = float(xd.x), y = float(xd.y), z = float(xd.z);
    const float cx = float(centre.x) - x, cy = float(centre.y) - y, cz = float(centre.z) - z,
                r2 = float(radius * radius);
    const std::size_t count = d.size();
    for (std::size_t j = 0; j < count; ++j) {
        const float dx = d.px[j] - x, dy = d.py[j] - y, dz = d.pz[j] - z;
        const float length2 = std::max(dx * dx + dy * dy + dz * dz, 1.0e-36f);
        const float t = std::clamp((cx * dx + cy * dy + cz * dz) / length2, 0.0f, 1.0f);
        const float qx = t * dx - cx, qy = t * dy - cy, qz = t * dz - cz;
        const bool near = (qx * qx + qy * qy + qz * qz <= r2) & (weights[j] > 0.0f); // no short-circuit: vectorises
        candidates[j] = near ? 1.0f : candidates[j];
    }
}

} // namespace

void validate(const DifferentialSettings& s) {
    const auto fail = [](const std::string& field, const std::string& expected) {
        throw Error("DifferentialSettings", std::nullopt, field + ": expected " + expected);
    };
    if (s.receiverStride < 1 || s.receiverStride > 64) fail("receiverStride", "1..64");
    if (!(s.falloffFraction > 0.0f && s.falloffFraction < 1.0f)) fail("falloffFraction", "a value in (0, 1)");
    if (s.emittersPerObject < 0 || s.emittersPerObject > 65536) fail("emittersPerObject", "0..65536");
    if (s.normalWindowRadius < 1 || s.normalWindowRadius > 16) fail("normalWindowRadius", "1..16");
    if (!(s.maxDepthChange > 0.0f)) fail("maxDepthChange", "> 0");
    if (!(s.minDepth >= 0.0f && s.maxDepth > s.minDepth)) fail("minDepth/maxDepth", "0 <= minDepth < maxDepth");
    if (!(s.rayEpsilon > 0.0 && s.rayEpsilon < 0.5)) fail("rayEpsilon", "a value in (0, 0.5)");
}

struct DifferentialIrradiance::Impl {
    DifferentialSettings settings;
    TriangleRayScene scene; ///< the virtual meshes, world frame
    std::vector<BoundingSphere> spheres;
    // Emitters: geometry fixed at create(), flux per frame.
    std::vector<glm::dvec3> emitterPosition, emitterNormal, emitterAlbedo;
    std::vector<double> emitterArea;
    std::vector<VirtualAreaLight> emitters;
    DiscArrays valArrays, emitterArrays;
    std::vector<DifferentialReceiver> receivers;
    int gridWidth = 0, gridHeight = 0;

    bool occluded(const glm::dvec3& from, const glm::dvec3& to) const {
        // unnormalised direction: t in [eps, 1 - eps] is the segment at any scale
        return scene.occluded(from, to - from, settings.rayEpsilon, 1.0 - settings.rayEpsilon);
    }

    /// Segment x-y blocked by a virtual mesh; the bounding spheres decide most segments without a ray.
    bool blocked(const glm::dvec3& x, const glm::dvec3& y, std::int64_t& rays) const {
        for (const BoundingSphere& s : spheres)
            if (segmentNearSphere(x, y, s)) {
                ++rays;
                return occluded(x, y);
            }
        return false;
    }

    /// Emitter flux of this frame from valArrays (assigned first) and the lights.
    void updateEmitters(std::span<const DifferentialLightSource> lights, std::int64_t& rays);
    void computeReceiver(const cv::Mat& depth, const CameraIntrinsics& k, const Pose& world_T_camera,
                         const Pose& camera_T_world, int i, int j, std::span<const VirtualAreaLight> vals,
                         std::span<const DifferentialLightSource> lights, DifferentialReceiver& r,
                         std::int64_t& rays) const;
    void interpolate(const cv::Mat& depth, DifferentialImages& out) const;
};

DifferentialIrradiance::DifferentialIrradiance() = default;
DifferentialIrradiance::~DifferentialIrradiance() = default;
DifferentialIrradiance::DifferentialIrradiance(DifferentialIrradiance&&) noexcept = default;
DifferentialIrradiance& DifferentialIrradiance::operator=(DifferentialIrradiance&&) noexcept = default;

DifferentialIrradiance DifferentialIrradiance::create(std::span<const MeshInstance> instances,
                                                      const DifferentialSettings& settings) {
    validate(settings);
    DifferentialIrradiance out;
    out.impl_ = std::make_unique<Impl>();
    Impl& impl = *out.impl_;
    impl.settings = settings;
    std::vector<RayMesh> rayMeshes;
    const double regionFactor = std::sqrt(1.0 / double(settings.falloffFraction) - 1.0);
    std::vector<glm::dvec3> world;
    std::vector<double> cumulative;
    for (std::size_t m = 0; m < instances.size(); ++m) {
        LIGHTSKIN_ASSERT(instances[m].mesh != nullptr,
                         "lightskin::gi::DifferentialIrradiance::create(): instance without a CPU mesh");
        const TriangleMesh& mesh = *instances[m].mesh;
        mesh.validate("differential: virtual object " + std::to_string(m));
        if (mesh.triangleCount() == 0) continue;
        const glm::dmat4 world_T_model(instances[m].world_T_model);
        world.resize(mesh.vertexCount());
        glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
        for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
            world[v] = glm::dvec3(world_T_model * glm::dvec4(toDouble(mesh.positions[v]), 1.0));
            lo = glm::min(lo, world[v]);
            hi = glm::max(hi, world[v]);
        }
        BoundingSphere sphere;
        sphere.centre = 0.5 * (lo + hi);
        for (const glm::dvec3& p : world) sphere.radius = std::max(sphere.radius, glm::length(p - sphere.centre));
        sphere.radius *= 1.0 + 1e-6; // float vertices exactly on the sphere stay inside
        sphere.regionRadius = sphere.radius * regionFactor;
        impl.spheres.push_back(sphere);

        rayMeshes.push_back({&mesh, world_T_model});

        // Emitters: N stratified points along the area CDF (first coordinate), the radical
        // inverse across each triangle (second), uniform in the triangle by the square-root map.
        const std::size_t n = std::size_t(settings.emittersPerObject);
        cumulative.assign(mesh.triangleCount(), 0.0);
        double total = 0.0;
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
            const glm::dvec3 &a = world[mesh.indices[3 * t]], &b = world[mesh.indices[3 * t + 1]],
                             &c = world[mesh.indices[3 * t + 2]];
            total += 0.5 * glm::length(glm::cross(b - a, c - a));
            cumulative[t] = total;
        }
        if (!(total > 0.0)) continue;
        for (std::size_t e = 0; e < n; ++e) {
            const double target = (double(e) + 0.5) / double(n) * total;
            const std::size_t t =
                std::size_t(std::lower_bound(cumulative.begin(), cumulative.end(), target) - cumulative.begin());
            const std::size_t tri = std::min(t, mesh.triangleCount() - 1);
            const double before = tri == 0 ? 0.0 : cumulative[tri - 1];
            const double area = cumulative[tri] - before;
            const double s = area > 0.0 ? std::clamp((target - before) / area, 0.0, 1.0) : 0.5;
            const double r = radicalInverse2(std::uint32_t(e));
            const glm::dvec3 &a = world[mesh.indices[3 * tri]], &b = world[mesh.indices[3 * tri + 1]],
                             &c = world[mesh.indices[3 * tri + 2]];
            const double su = std::sqrt(s);
            const glm::dvec3 p = a * (1.0 - su) + b * (su * (1.0 - r)) + c * (su * r);
            const glm::dvec3 normal = glm::cross(b - a, c - a);
            if (!(glm::length(normal) > 0.0)) continue;
            impl.emitterPosition.push_back(p);
            impl.emitterNormal.push_back(glm::normalize(normal)); // counter-clockwise front faces (TriangleMesh)
            impl.emitterArea.push_back(total / double(n));
            impl.emitterAlbedo.push_back(toDouble(instances[m].material.diffuseAlbedo));
        }
    }
    impl.scene = TriangleRayScene::create(rayMeshes, "differential");
    impl.emitters.resize(impl.emitterPosition.size());
    return out;
}

void DifferentialIrradiance::Impl::updateEmitters(std::span<const DifferentialLightSource> lights, std::int64_t& rays) {
    std::atomic<std::int64_t> rayCount{0};
    cv::parallel_for_(cv::Range(0, int(emitters.size())), [&](const cv::Range& range) {
        std::int64_t localRays = 0;
        for (int e = range.start; e < range.end; ++e) {
            const std::size_t k = std::size_t(e);
            const glm::dvec3 &x = emitterPosition[k], &n = emitterNormal[k];
            glm::dvec3 irradiance(0.0);
            for (const DifferentialLightSource& source : lights) {
                const glm::dvec3 direct = lightIrradiance(x, n, source.light);
                if (direct == glm::dvec3(0.0)) continue;
                ++localRays;
                if (!occluded(x, toDouble(source.light.position))) irradiance += direct;
            }
            thread_local std::vector<float> weights;
            weights.resize(valArrays.size());
            irradiance += gatherDiscs(valArrays, x, n, weights.data());
            VirtualAreaLight& out = emitters[k];
            out.position = glm::vec3(x);
            out.normal = glm::vec3(n);
            out.area = float(emitterArea[k]);
            const glm::dvec3 flux =
                emitterAlbedo[k] * irradiance * emitterArea[k]; // Lambertian exitance rho E times area
            out.flux = finite(flux) ? glm::vec3(flux) : glm::vec3(0.0f);
        }
        rayCount += localRays;
    });
    rays += rayCount.load();
}

/// Real geometry between a receiver and a light, from the depth frame alone (a screen-space
/// shadow ray): 48 samples along the segment (the first 2 cm skipped: the receiver's own surface);
/// a sample that projects onto a valid depth pixel and lies behind it by more than
/// max(2 cm, 3 % z) (the depth noise and the normal window's smoothing) but less than 0.5 m (real
/// objects are assumed no thinner than the camera can tell apart: a table top and its body, not a
/// sheet) is inside real matter, so the light does not reach the receiver.
bool reallyOccluded(const cv::Mat& depth, const CameraIntrinsics& k, const Pose& camera_T_world, const glm::dvec3& from,
                    const glm::dvec3& to) {
    constexpr int kSamples = 48;
    const double length = glm::length(to - from);
    if (!(length > 0.02)) return false;
    for (int step = 0; step < kSamples; ++step) {
        const double t = 0.02 / length + (1.0 - 0.02 / length) * (double(step) + 0.5) / kSamples;
        const glm::dvec3 c = camera_T_world.transformPoint(from + t * (to - from));
        if (c.z <= 0.05) continue;
        const double u = k.fx * c.x / c.z + k.cx, v = k.fy * c.y / c.z + k.cy;
        const long pu = std::lround(u), pv = std::lround(v);
        if (pu < 0 || pv < 0 || pu >= depth.cols || pv >= depth.rows) continue;
        const double real = double(depth.at<float>(int(pv), int(pu)));
        if (!(real > 0.0) || !std::isfinite(real)) continue;
        const double behind = c.z - real;
        if (behind > std::max(0.02, 0.03 * real) && behind < 0.5) return true;
    }
    return false;
}

void DifferentialIrradiance::Impl::computeReceiver(const cv::Mat& depth, const CameraIntrinsics& k,
                                                   const Pose& world_T_camera, const Pose& camera_T_world, int i, int j,
                                                   std::span<const VirtualAreaLight> vals,
                                                   std::span<const DifferentialLightSource> lights,
                                                   DifferentialReceiver& r, std::int64_t& rays) const {
    r = DifferentialReceiver{};
    const int s = settings.receiverStride, R = settings.normalWindowRadius;
    const int cu = i * s + s / 2, cv = j * s + s / 2;
    if (cu - R < 0 || cv - R < 0 || cu + R >= depth.cols || cv + R >= depth.rows) return;
    const auto z = [&depth](int u, int v) { return depth.at<float>(v, u); };
    const auto valid = [this](float d) { return d > settings.minDepth && d <= settings.maxDepth; };
    const auto backProject = [&k](int u, int v, double d) {
        return glm::dvec3((double(u) - k.cx) * d / k.fx, (double(v) - k.cy) * d / k.fy, d);
    };
    const float zc = z(cu, cv);
    if (!valid(zc)) return;
    const float maxStep = settings.maxDepthChange * zc;
    // ValGenerator's edge test and AVERAGE_3D_GRADIENT normal (gi/shaders/val_from_depth.comp).
    const int arms[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
    for (const auto& arm : arms) {
        float previous = zc;
        for (int step = 1; step <= R; ++step) {
            const float d = z(cu + arm[0] * step, cv + arm[1] * step);
            if (!valid(d) || std::abs(d - previous) > maxStep) return;
            previous = d;
        }
    }
    glm::dvec3 gx(0.0), gy(0.0);
    float prevL = z(cu - R, cv - R), prevR = z(cu + R, cv - R), prevT = z(cu - R, cv - R), prevB = z(cu - R, cv + R);
    for (int d = -R; d <= R; ++d) {
        const float zl = z(cu - R, cv + d), zr = z(cu + R, cv + d), zt = z(cu + d, cv - R), zb = z(cu + d, cv + R);
        if (!valid(zl) || !valid(zr) || !valid(zt) || !valid(zb)) return;
        if (std::abs(zl - prevL) > maxStep || std::abs(zr - prevR) > maxStep || std::abs(zt - prevT) > maxStep ||
            std::abs(zb - prevB) > maxStep)
            return;
        prevL = zl;
        prevR = zr;
        prevT = zt;
        prevB = zb;
        gx += backProject(cu + R, cv + d, zr) - backProject(cu - R, cv + d, zl);
        gy += backProject(cu + d, cv + R, zb) - backProject(cu + d, cv - R, zt);
    }
    glm::dvec3 n = glm::cross(gy, gx);
    const double length = glm::length(n);
    if (!(length > 0.0) || !std::isfinite(length)) return;
    n /= length;
    const glm::dvec3 p = backProject(cu, cv, zc);
    if (glm::dot(n, p) > 0.0) n = -n; // toward the camera
    r.position = world_T_camera.transformPoint(p);
    r.normal = glm::normalize(world_T_camera.transformDirection(n));
    r.depth = zc;
    r.valid = true;

    // Region (header): near an object, or an object's bounding sphere between it and a light.
    for (const BoundingSphere& sphere : spheres) {
        const glm::dvec3 offset = r.position - sphere.centre;
        r.inRegion = r.inRegion || glm::dot(offset, offset) <= sphere.regionRadius * sphere.regionRadius;
        for (const DifferentialLightSource& source : lights)
            r.inRegion = r.inRegion || segmentNearSphere(r.position, toDouble(source.light.position), sphere);
    }
    if (!r.inRegion) return;

    const glm::dvec3 &x = r.position, &nx = r.normal;
    thread_local std::vector<float> weights, candidates;
    weights.resize(std::max(valArrays.size(), emitterArrays.size()));
    candidates.assign(valArrays.size(), 0.0f); // keeps capacity
    glm::dvec3 without = gatherDiscs(valArrays, x, nx, weights.data()), delta(0.0);
    for (const BoundingSphere& sphere : spheres)
        markNearSphere(valArrays, x, sphere.centre, sphere.radius, weights.data(), candidates.data());
    for (std::size_t v = 0; v < vals.size(); ++v) {
        if (candidates[v] == 0.0f) continue;
        ++rays;
        if (occluded(x, glm::dvec3(valArrays.px[v], valArrays.py[v], valArrays.pz[v]))) // the indirect shadow
            delta -= glm::dvec3(valArrays.fr[v], valArrays.fg[v], valArrays.fb[v]) * double(weights[v]);
    }
    for (const DifferentialLightSource& source : lights) {
        const glm::dvec3 e = lightIrradiance(x, nx, source.light);
        if (e == glm::dvec3(0.0)) continue;
        if (reallyOccluded(depth, k, camera_T_world, x, toDouble(source.light.position))) continue; // in neither image
        const bool shadowed = blocked(x, toDouble(source.light.position), rays);
        if (source.inRoom) {
            without += e;
            if (shadowed) delta -= e;
        } else if (!shadowed) {
            delta += e;
        }
    }
    delta += gatherDiscs(emitterArrays, x, nx, weights.data()); // the light the objects reflect
    r.irradianceWithout = finite(without) ? without : glm::dvec3(0.0);
    r.deltaIrradiance = finite(delta) ? delta : glm::dvec3(0.0);
}

void DifferentialIrradiance::Impl::interpolate(const cv::Mat& depth, DifferentialImages& out) const {
    const int s = settings.receiverStride;
    const float relative = settings.maxDepthChange;
    cv::parallel_for_(cv::Range(0, depth.rows), [&](const cv::Range& range) {
        for (int v = range.start; v < range.end; ++v) {
            auto* delta = out.deltaIrradiance.ptr<cv::Vec3f>(v);
            auto* without = out.irradianceWithout.ptr<cv::Vec3f>(v);
            auto* affected = out.affected.ptr<std::uint8_t>(v);
            const float* zRow = depth.ptr<float>(v);
            // Grid node j sits at pixel row j s + s/2.
            const double gy = (double(v) - double(s / 2)) / double(s);
            const int j0 = int(std::floor(gy));
            const double fy = gy - double(j0);
            for (int u = 0; u < depth.cols; ++u) {
                const float zp = zRow[u];
                if (!(zp > settings.minDepth && zp <= settings.maxDepth)) continue;
                const double gx = (double(u) - double(s / 2)) / double(s);
                const int i0 = int(std::floor(gx));
                const double fx = gx - double(i0);
                double weightSum = 0.0;
                glm::dvec3 d(0.0), w(0.0);
                for (int dj = 0; dj < 2; ++dj)
                    for (int di = 0; di < 2; ++di) {
                        const int i = i0 + di, j = j0 + dj;
                        if (i < 0 || j < 0 || i >= gridWidth || j >= gridHeight) continue;
                        const DifferentialReceiver& r =
                            receivers[std::size_t(j) * std::size_t(gridWidth) + std::size_t(i)];
                        if (!r.inRegion) continue;
                        const int distance = std::max(std::abs(u - (i * s + s / 2)), std::abs(v - (j * s + s / 2)));
                        if (std::abs(r.depth - zp) > relative * zp * float(std::max(1, distance)))
                            continue; // another surface
                        const double weight = (di == 0 ? 1.0 - fx : fx) * (dj == 0 ? 1.0 - fy : fy);
                        if (!(weight > 0.0)) continue;
                        weightSum += weight;
                        d += weight * r.deltaIrradiance;
                        w += weight * r.irradianceWithout;
                    }
                if (!(weightSum > 0.0)) continue;
                d /= weightSum;
                w /= weightSum;
                delta[u] = cv::Vec3f(float(d.z), float(d.y), float(d.x)); // RGB -> BGR
                without[u] = cv::Vec3f(float(w.z), float(w.y), float(w.x));
                affected[u] = 255;
            }
        }
    });
}

void DifferentialIrradiance::compute(const cv::Mat& depthMetres, const CameraIntrinsics& intrinsics,
                                     const Pose& world_T_camera, std::span<const VirtualAreaLight> vals,
                                     std::span<const DifferentialLightSource> lights, DifferentialImages& out) {
    LIGHTSKIN_ASSERT(impl_, "lightskin::gi::DifferentialIrradiance::compute(): used before create()");
    LIGHTSKIN_ASSERT(depthMetres.type() == CV_32FC1,
                     "lightskin::gi::DifferentialIrradiance::compute(): depth must be CV_32FC1 metres");
    Impl& impl = *impl_;
    const int s = impl.settings.receiverStride;
    impl.gridWidth = depthMetres.cols / s;
    impl.gridHeight = depthMetres.rows / s;
    impl.receivers.resize(std::size_t(impl.gridWidth) * std::size_t(impl.gridHeight));
    out.deltaIrradiance.create(depthMetres.size(), CV_32FC3);
    out.irradianceWithout.create(depthMetres.size(), CV_32FC3);
    out.affected.create(depthMetres.size(), CV_8UC1);
    out.deltaIrradiance.setTo(cv::Scalar::all(0));
    out.irradianceWithout.setTo(cv::Scalar::all(0));
    out.affected.setTo(cv::Scalar::all(0));
    out.receiversGathered = 0;
    out.shadowRays = 0;

    impl.valArrays.assign(vals);
    impl.updateEmitters(lights, out.shadowRays);
    impl.emitterArrays.assign(impl.emitters);
    const Pose camera_T_world = world_T_camera.inverse();
    std::atomic<std::int64_t> rays{0}, gathered{0};
    cv::parallel_for_(cv::Range(0, impl.gridHeight), [&](const cv::Range& range) {
        std::int64_t localRays = 0, localGathered = 0;
        for (int j = range.start; j < range.end; ++j)
            for (int i = 0; i < impl.gridWidth; ++i) {
                DifferentialReceiver& r = impl.receivers[std::size_t(j) * std::size_t(impl.gridWidth) + std::size_t(i)];
                impl.computeReceiver(depthMetres, intrinsics, world_T_camera, camera_T_world, i, j, vals, lights, r,
                                     localRays);
                if (r.inRegion) ++localGathered;
            }
        rays += localRays;
        gathered += localGathered;
    });
    out.shadowRays += rays.load();
    out.receiversGathered = gathered.load();
    impl.interpolate(depthMetres, out);
}

std::span<const DifferentialReceiver> DifferentialIrradiance::receivers() const noexcept { return impl_->receivers; }
int DifferentialIrradiance::gridWidth() const noexcept { return impl_->gridWidth; }
int DifferentialIrradiance::gridHeight() const noexcept { return impl_->gridHeight; }
std::span<const VirtualAreaLight> DifferentialIrradiance::emitters() const noexcept { return impl_->emitters; }
const DifferentialSettings& DifferentialIrradiance::settings() const noexcept { return impl_->settings; }

void downloadValsInto(const ValSetView& set, std::vector<VirtualAreaLight>& out) {
    out.resize(set.count);
    if (set.count == 0) return;
    glGetNamedBufferSubData(set.buffer, 0, GLsizeiptr(sizeof(VirtualAreaLight) * set.count), out.data());
}

} // namespace lightskin::gi
