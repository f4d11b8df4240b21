#include <lightskin/core/Error.h>
#include <lightskin/gi/common/TriangleRayScene.h>
#include <lightskin/render/MeshLoader.h>
#include <lightskin/render/Scene.h>
#include <lightskin/synth/PresentObjects.h>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace lightskin::synth {

namespace {

constexpr double kPi = std::numbers::pi;

struct LightSample {
    glm::dvec3 position, normal, intensity; ///< intensity W/sr along the normal (isotropic: everywhere)
    bool isotropic = true;
};

/// The room's light samples exactly as SceneRenderer builds them (point: P / 4 pi; area: midpoint
/// rule, each cell P / (pi n^2) along its normal).
std::vector<LightSample> lightSamples(const SceneDescription& scene) {
    std::vector<LightSample> samples;
    for (const LightDescription& light : scene.lights) {
        const glm::dvec3 power(light.powerWatts);
        if (light.type == LightType::Point) {
            samples.push_back({light.placement.position, glm::dvec3(0.0), power / (4.0 * kPi), true});
            continue;
        }
        const Pose world_T_light = light.placement.world_T_face();
        const glm::dvec3 facing = glm::normalize(light.placement.facing);
        const int n = light.samples;
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                samples.push_back({world_T_light.transformPoint({((i + 0.5) / n - 0.5) * light.size.x,
                                                                 ((j + 0.5) / n - 0.5) * light.size.y, 0.0}),
                                   facing, power / (kPi * double(n * n)), false});
    }
    return samples;
}

struct Box {
    glm::dmat3 rotationT; ///< box_T_world rotation
    glm::dvec3 center, half;
};

/// The open segment a + t (b - a), t in (1e-4, 1 - 1e-4), crosses the box (the renderer's test).
bool segmentHitsBox(const glm::dvec3& a, const glm::dvec3& b, const Box& box) {
    const glm::dvec3 o = box.rotationT * (a - box.center), d = box.rotationT * (b - a);
    double enter = -std::numeric_limits<double>::infinity(), leave = std::numeric_limits<double>::infinity();
    for (int axis = 0; axis < 3; ++axis) {
        if (d[axis] == 0.0) {
            if (std::abs(o[axis]) > box.half[axis]) return false;
            continue;
        }
        double t0 = (-box.half[axis] - o[axis]) / d[axis], t1 = (box.half[axis] - o[axis]) / d[axis];
        if (t0 > t1) std::swap(t0, t1);
        enter = std::max(enter, t0);
        leave = std::min(leave, t1);
    }
    return enter <= leave && leave > 1e-4 && enter < 1.0 - 1e-4;
}

struct Disc {
    glm::dvec3 position, normal;
    double area = 0.0;
    glm::dvec3 radiance{0.0}; ///< emitted (outgoing) radiance, Lambertian
};

/// Irradiance at (x, n) from a Lambertian disc: L pi r^2 cos_d cos_x / (r^2 + d^2).
glm::dvec3 discIrradiance(const glm::dvec3& x, const glm::dvec3& n, const Disc& disc) {
    const glm::dvec3 offset = disc.position - x;
    const double d2 = glm::dot(offset, offset);
    if (!(d2 > 0.0)) return glm::dvec3(0.0);
    const glm::dvec3 l = offset / std::sqrt(d2);
    const double cosX = glm::dot(n, l), cosD = -glm::dot(disc.normal, l);
    if (!(cosX > 0.0) || !(cosD > 0.0)) return glm::dvec3(0.0);
    const double r2 = disc.area / kPi;
    return disc.radiance * (kPi * r2 * cosD * cosX / (r2 + d2));
}

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

} // namespace

std::vector<PresentObject> loadPresentObjects(const std::filesystem::path& lightskinScene) {
    const render::Scene scene = render::loadScene(lightskinScene);
    if (scene.objects.empty())
        throw Error(lightskinScene.string(), std::nullopt, "the scene has no objects to place in the room");
    std::vector<PresentObject> objects;
    for (const render::SceneObject& so : scene.objects) {
        const render::LoadedModel model = render::loadModel(so.mesh);
        const glm::dmat4 world_T_model(so.world_T_model);
        const glm::dmat3 normalMatrix = glm::transpose(glm::inverse(glm::dmat3(world_T_model)));
        for (const render::MeshPart& part : model.parts) {
            PresentObject o;
            o.name = so.name + (part.name.empty() ? "" : "/" + part.name);
            o.mesh = part.mesh;
            for (glm::vec3& p : o.mesh.positions) p = glm::vec3(world_T_model * glm::dvec4(glm::dvec3(p), 1.0));
            for (glm::vec3& n : o.mesh.normals) n = glm::vec3(glm::normalize(normalMatrix * glm::dvec3(n)));
            o.material = part.material;
            if (so.material.diffuseAlbedo) o.material.diffuseAlbedo = *so.material.diffuseAlbedo;
            if (so.material.specularAlbedo) o.material.specularAlbedo = *so.material.specularAlbedo;
            if (so.material.specularExponent) o.material.specularExponent = *so.material.specularExponent;
            objects.push_back(std::move(o));
        }
    }
    return objects;
}

struct PresentObjects::Impl {
    SceneDescription room;
    std::vector<PresentObject> objects;
    std::vector<LightSample> lights;
    std::vector<Box> boxes;
    std::vector<Disc> emitters;  ///< on the objects, radiance rho_d E / pi (fixed: static lights and objects)
    std::vector<Disc> roomDiscs; ///< the room seen from the objects (cube maps)
    gi::TriangleRayScene scene;  ///< the objects (world frame); a hit's mesh index is the object's

    bool objectBetween(const glm::dvec3& a, const glm::dvec3& b) const {
        return scene.occluded(a, b - a, double(1e-4f), double(1.0f - 1e-4f));
    }

    bool boxBetween(const glm::dvec3& a, const glm::dvec3& b) const {
        return std::any_of(boxes.begin(), boxes.end(), [&](const Box& box) { return segmentHitsBox(a, b, box); });
    }

    /// Direct irradiance per light sample at (x, n) (origin moved 1e-4 m off the surface, as the
    /// renderer does): `withBoxes` with box visibility; `withObjects` also with the objects'.
    void direct(const glm::dvec3& position, const glm::dvec3& n, glm::dvec3& withBoxes, glm::dvec3& withObjects,
                const glm::dvec3* toViewer = nullptr, const Material* material = nullptr,
                glm::dvec3* specular = nullptr) const {
        const glm::dvec3 origin = position + 1e-4 * n;
        for (const LightSample& s : lights) {
            const glm::dvec3 toLight = s.position - origin;
            const double d2 = glm::dot(toLight, toLight);
            const glm::dvec3 l = toLight / std::sqrt(d2);
            const double cosReceiver = glm::dot(n, l);
            if (!(cosReceiver > 0.0)) continue;
            const double cosEmitter = s.isotropic ? 1.0 : std::max(0.0, -glm::dot(s.normal, l));
            if (!(cosEmitter > 0.0)) continue;
            if (boxBetween(origin, s.position)) continue;
            const glm::dvec3 e = s.intensity * (cosEmitter * cosReceiver / d2);
            withBoxes += e;
            if (objectBetween(origin, s.position)) continue;
            withObjects += e;
            if (specular != nullptr && material->hasSpecular()) {
                const glm::dvec3 mirror = 2.0 * cosReceiver * n - l;
                const double cosGamma = std::max(0.0, glm::dot(mirror, *toViewer));
                const double k = double(material->specularExponent);
                *specular +=
                    glm::dvec3(material->specularAlbedo) * ((k + 2.0) / (2.0 * kPi) * std::pow(cosGamma, k)) * e;
            }
        }
    }

    /// The room's one bounce at an object point, visibility against the objects.
    glm::dvec3 roomBounce(const glm::dvec3& y, const glm::dvec3& n) const {
        glm::dvec3 e(0.0);
        for (const Disc& disc : roomDiscs) {
            const glm::dvec3 contribution = discIrradiance(y, n, disc);
            if (contribution == glm::dvec3(0.0)) continue;
            if (!objectBetween(y + 1e-4 * n, disc.position)) e += contribution;
        }
        return e;
    }
};

PresentObjects::PresentObjects() = default;
PresentObjects::~PresentObjects() = default;
PresentObjects::PresentObjects(PresentObjects&&) noexcept = default;
PresentObjects& PresentObjects::operator=(PresentObjects&&) noexcept = default;

PresentObjects PresentObjects::create(const SceneDescription& room, std::vector<PresentObject> objects,
                                      const TagBitmapSource& tags, const PresentObjectsSettings& settings) {
    const std::string source = room.sourcePath.string();
    if (settings.emittersPerObject < 1 || settings.roomCubeSize < 2 || settings.roomCubeSize > 256)
        throw Error(source, std::nullopt, "objects present: need emittersPerObject >= 1 and roomCubeSize in [2, 256]");
    if (objects.empty()) throw Error(source, std::nullopt, "objects present: no objects");
    PresentObjects out;
    out.impl_ = std::make_unique<Impl>();
    Impl& impl = *out.impl_;
    impl.room = room;
    impl.objects = std::move(objects);
    impl.lights = lightSamples(room);
    for (const BoxDescription& b : room.boxes) {
        const double yaw = b.yawDegrees * kPi / 180.0;
        const glm::dmat3 rotation(glm::dvec3(std::cos(yaw), std::sin(yaw), 0.0),
                                  glm::dvec3(-std::sin(yaw), std::cos(yaw), 0.0), glm::dvec3(0.0, 0.0, 1.0));
        impl.boxes.push_back({glm::transpose(rotation), b.center, b.size / 2.0});
    }
    std::vector<gi::RayMesh> rayMeshes;
    for (const PresentObject& object : impl.objects) {
        object.mesh.validate("objects present: " + object.name);
        rayMeshes.push_back({&object.mesh, glm::dmat4(1.0)}); // positions are world already
    }
    impl.scene = gi::TriangleRayScene::create(rayMeshes, "objects present");

    // The room seen from each object's bounding-sphere centre: six 90-degree faces.
    SceneDescription cubeScene = room;
    const int n = settings.roomCubeSize;
    cubeScene.intrinsics = CameraIntrinsics{
        .width = n, .height = n, .fx = n / 2.0, .fy = n / 2.0, .cx = (n - 1) / 2.0, .cy = (n - 1) / 2.0};
    cubeScene.supersampling = 1;
    SceneRenderer cubeRenderer = SceneRenderer::create(cubeScene, tags);
    RenderedView face;
    for (const PresentObject& object : impl.objects) {
        glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
        for (const glm::vec3& p : object.mesh.positions) {
            lo = glm::min(lo, glm::dvec3(p));
            hi = glm::max(hi, glm::dvec3(p));
        }
        const glm::dvec3 centre = 0.5 * (lo + hi);
        const glm::dvec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
        for (const glm::dvec3& forward : axes) {
            const glm::dvec3 helper = std::abs(forward.z) > 0.5 ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1);
            const glm::dvec3 right = glm::normalize(glm::cross(forward, helper)), down = glm::cross(forward, right);
            const Pose world_T_camera = Pose::fromMatrix(
                glm::dmat4(glm::dvec4(right, 0), glm::dvec4(down, 0), glm::dvec4(forward, 0), glm::dvec4(centre, 1)));
            cubeRenderer.renderInto(world_T_camera, face);
            for (int v = 0; v < n; ++v)
                for (int u = 0; u < n; ++u) {
                    const double z = double(face.depthMetres.at<float>(v, u));
                    if (!(z > 0.0)) continue;
                    const cv::Vec3f p = face.worldPosition.at<cv::Vec3f>(v, u),
                                    nn = face.worldNormal.at<cv::Vec3f>(v, u),
                                    radiance = face.radiance.at<cv::Vec3f>(v, u);
                    const glm::dvec3 position(p[0], p[1], p[2]), normal(nn[0], nn[1], nn[2]);
                    const glm::dvec3 ray = glm::normalize(position - centre);
                    // Texel solid angle (2/n)^2 cos^3(alpha), area omega d^2 / cos(theta) (cos clamped at 0.2).
                    const double cosAlpha = glm::dot(ray, forward), d2 = glm::dot(position - centre, position - centre);
                    const double omega = (2.0 / n) * (2.0 / n) * cosAlpha * cosAlpha * cosAlpha;
                    const double cosTheta = std::max(0.2, std::abs(glm::dot(normal, ray)));
                    impl.roomDiscs.push_back({position, glm::dot(normal, ray) > 0.0 ? -normal : normal,
                                              omega * d2 / cosTheta,
                                              glm::dvec3(radiance[2], radiance[1], radiance[0])});
                }
        }
    }

    // Emitters: area-weighted points (stratified along the area CDF), radiance rho_d E / pi with
    // E = direct light (exact visibility) + the room's one bounce.
    for (const PresentObject& object : impl.objects) {
        const TriangleMesh& mesh = object.mesh;
        std::vector<double> cumulative(mesh.triangleCount());
        double total = 0.0;
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
            const glm::dvec3 a(mesh.positions[mesh.indices[3 * t]]), b(mesh.positions[mesh.indices[3 * t + 1]]),
                c(mesh.positions[mesh.indices[3 * t + 2]]);
            total += 0.5 * glm::length(glm::cross(b - a, c - a));
            cumulative[t] = total;
        }
        if (!(total > 0.0)) continue;
        const int count = settings.emittersPerObject;
        for (int e = 0; e < count; ++e) {
            const double target = (e + 0.5) / count * total;
            const std::size_t t = std::min(
                std::size_t(std::lower_bound(cumulative.begin(), cumulative.end(), target) - cumulative.begin()),
                mesh.triangleCount() - 1);
            const double before = t == 0 ? 0.0 : cumulative[t - 1], area = cumulative[t] - before;
            const double s = area > 0.0 ? std::clamp((target - before) / area, 0.0, 1.0) : 0.5,
                         r = std::fmod(e * 0.6180339887498949, 1.0);
            const glm::dvec3 a(mesh.positions[mesh.indices[3 * t]]), b(mesh.positions[mesh.indices[3 * t + 1]]),
                c(mesh.positions[mesh.indices[3 * t + 2]]);
            const double su = std::sqrt(s);
            const glm::dvec3 p = a * (1.0 - su) + b * (su * (1.0 - r)) + c * (su * r);
            const glm::dvec3 cross = glm::cross(b - a, c - a);
            if (!(glm::length(cross) > 0.0)) continue;
            const glm::dvec3 normal = glm::normalize(cross);
            glm::dvec3 withBoxes(0.0), withObjects(0.0);
            impl.direct(p, normal, withBoxes, withObjects);
            const glm::dvec3 irradiance = withObjects + impl.roomBounce(p, normal);
            impl.emitters.push_back(
                {p, normal, total / count, glm::dvec3(object.material.diffuseAlbedo) * irradiance / kPi});
        }
    }
    return out;
}

void PresentObjects::renderInto(const Pose& world_T_camera, const RenderedView& room, cv::Mat& out) const {
    LIGHTSKIN_ASSERT(impl_, "lightskin::synth::PresentObjects::renderInto(): used before create()");
    const Impl& impl = *impl_;
    const CameraIntrinsics& k = impl.room.intrinsics;
    LIGHTSKIN_ASSERT(room.radiance.type() == CV_32FC3 && room.radiance.cols == k.width &&
                         room.radiance.rows == k.height,
                     "lightskin::synth::PresentObjects::renderInto(): the room view must be the scene's size");
    room.radiance.copyTo(out);
    const glm::dvec3 ambient(impl.room.ambientRadiance);
    const glm::dvec3 eye = world_T_camera.translation();
    cv::parallel_for_(cv::Range(0, k.height), [&](const cv::Range& rows) {
        for (int v = rows.start; v < rows.end; ++v)
            for (int u = 0; u < k.width; ++u) {
                const glm::dvec3 direction =
                    world_T_camera.transformDirection({(u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0});
                const double roomZ =
                    double(room.depthMetres.at<float>(v, u)); // the ray parameter (camera z = 1 per unit)
                const std::optional<gi::RayHit> hit = impl.scene.intersect(
                    eye, direction, 0.0, roomZ > 0.0 ? double(float(roomZ)) : std::numeric_limits<double>::infinity());
                cv::Vec3f& pixel = out.at<cv::Vec3f>(v, u);
                if (hit) {
                    // An object: smooth normal from the vertex normals, facing the camera.
                    const PresentObject& object = impl.objects[hit->mesh];
                    const TriangleMesh& mesh = object.mesh;
                    const std::size_t t = hit->triangle;
                    const double bu = hit->u, bv = hit->v;
                    glm::dvec3 n = glm::normalize((1.0 - bu - bv) * glm::dvec3(mesh.normals[mesh.indices[3 * t]]) +
                                                  bu * glm::dvec3(mesh.normals[mesh.indices[3 * t + 1]]) +
                                                  bv * glm::dvec3(mesh.normals[mesh.indices[3 * t + 2]]));
                    if (glm::dot(n, direction) > 0.0) n = -n;
                    const glm::dvec3 y = eye + hit->t * direction, toViewer = glm::normalize(-direction);
                    glm::dvec3 withBoxes(0.0), withObjects(0.0), specular(0.0);
                    impl.direct(y, n, withBoxes, withObjects, &toViewer, &object.material, &specular);
                    const glm::dvec3 rho(object.material.diffuseAlbedo);
                    const glm::dvec3 radiance =
                        rho / kPi * (withObjects + impl.roomBounce(y, n)) + rho * ambient + specular;
                    if (finite(radiance)) pixel = cv::Vec3f(float(radiance.z), float(radiance.y), float(radiance.x));
                    continue;
                }
                if (!(roomZ > 0.0)) continue;
                // The room: exact light ratio with the objects as occluders, plus their bounce.
                const cv::Vec3f p = room.worldPosition.at<cv::Vec3f>(v, u), nn = room.worldNormal.at<cv::Vec3f>(v, u);
                const glm::dvec3 x(p[0], p[1], p[2]), n(nn[0], nn[1], nn[2]);
                glm::dvec3 withBoxes(0.0), withObjects(0.0), bounce(0.0);
                impl.direct(x, n, withBoxes, withObjects);
                for (const Disc& emitter : impl.emitters) bounce += discIrradiance(x, n, emitter);
                for (int c = 0; c < 3; ++c) {
                    const double base = withBoxes[c] + kPi * ambient[c];
                    if (!(base > 0.0)) continue;
                    const double radiance = double(pixel[2 - c]); // BGR
                    const double present =
                        radiance * (withObjects[c] + kPi * ambient[c]) / base + radiance / base * bounce[c];
                    if (std::isfinite(present)) pixel[2 - c] = float(present);
                }
            }
    });
}

} // namespace lightskin::synth
