#include "PrtRayScene.h"

#include <lightskin/core/Error.h>

#include <embree3/rtcore.h>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace lightskin::gi::detail {

struct PrtRayScene::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    std::vector<Triangle> triangles;
    std::vector<std::uint32_t> firstTriangle; // per geometry (= instance)
    std::vector<glm::vec3> albedo;            // per instance
    float diagonal = 0.0f;
    glm::vec3 averageAlbedo{0.0f};
    ~Impl() {
        if (scene) rtcReleaseScene(scene);
        if (device) rtcReleaseDevice(device);
    }
};

PrtRayScene::PrtRayScene() = default;
PrtRayScene::~PrtRayScene() = default;
PrtRayScene::PrtRayScene(PrtRayScene&&) noexcept = default;
PrtRayScene& PrtRayScene::operator=(PrtRayScene&&) noexcept = default;

namespace {
void throwIfEmbreeError(RTCDevice device, const char* what) {
    const RTCError error = rtcGetDeviceError(device);
    if (error != RTC_ERROR_NONE)
        throw Error("embree", std::nullopt,
                    std::string(what) + " failed (RTCError " + std::to_string(int(error)) + ")");
}
} // namespace

PrtRayScene PrtRayScene::create(std::span<const MeshInstance> instances) {
    PrtRayScene out;
    out.impl_ = std::make_unique<Impl>();
    Impl& impl = *out.impl_;
    impl.device = rtcNewDevice("threads=1");
    if (!impl.device) throw Error("embree", std::nullopt, "rtcNewDevice failed");
    impl.scene = rtcNewScene(impl.device);
    rtcSetSceneFlags(impl.scene, RTC_SCENE_FLAG_ROBUST);
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    glm::dvec3 albedoSum(0.0);
    double areaSum = 0.0;
    for (std::size_t m = 0; m < instances.size(); ++m) {
        LIGHTSKIN_ASSERT(instances[m].mesh != nullptr,
                         "lightskin::gi::detail::PrtRayScene::create(): instance without a mesh");
        const TriangleMesh& mesh = *instances[m].mesh;
        mesh.validate("multiscale-prt mesh " + std::to_string(m));
        impl.firstTriangle.push_back(std::uint32_t(impl.triangles.size()));
        impl.albedo.push_back(instances[m].material.diffuseAlbedo);
        RTCGeometry geometry = rtcNewGeometry(impl.device, RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
            geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), mesh.vertexCount()));
        auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
            geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), mesh.triangleCount()));
        throwIfEmbreeError(impl.device, "creating geometry buffers");
        std::vector<glm::vec3> world(mesh.vertexCount());
        for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
            world[v] = glm::vec3(instances[m].world_T_model * glm::vec4(mesh.positions[v], 1.0f));
            lo = glm::min(lo, world[v]);
            hi = glm::max(hi, world[v]);
            for (int k = 0; k < 3; ++k) vertices[3 * v + std::size_t(k)] = world[v][k];
        }
        for (std::size_t i = 0; i < mesh.indices.size(); ++i) indices[i] = mesh.indices[i];
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
            Triangle tri;
            tri.a = world[mesh.indices[3 * t]];
            tri.b = world[mesh.indices[3 * t + 1]];
            tri.c = world[mesh.indices[3 * t + 2]];
            const glm::vec3 cross = glm::cross(tri.b - tri.a, tri.c - tri.a);
            const float length = glm::length(cross);
            tri.area = 0.5f * length;
            tri.normal = length > 0.0f ? cross / length : glm::vec3(0.0f, 0.0f, 1.0f);
            tri.instance = std::uint32_t(m);
            impl.triangles.push_back(tri);
            albedoSum += double(tri.area) * glm::dvec3(instances[m].material.diffuseAlbedo);
            areaSum += double(tri.area);
        }
        rtcCommitGeometry(geometry);
        rtcAttachGeometry(impl.scene, geometry); // ids 0, 1, ... in order: geomID = instance
        rtcReleaseGeometry(geometry);
    }
    rtcCommitScene(impl.scene);
    throwIfEmbreeError(impl.device, "building the scene");
    impl.diagonal = impl.triangles.empty() ? 0.0f : glm::length(hi - lo);
    impl.averageAlbedo = areaSum > 0.0 ? glm::vec3(albedoSum / areaSum) : glm::vec3(0.0f);
    return out;
}

PrtHit PrtRayScene::intersect(const glm::vec3& origin, const glm::vec3& direction, float tnear, float tfar) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit rayHit{};
    rayHit.ray.org_x = origin.x;
    rayHit.ray.org_y = origin.y;
    rayHit.ray.org_z = origin.z;
    rayHit.ray.dir_x = direction.x;
    rayHit.ray.dir_y = direction.y;
    rayHit.ray.dir_z = direction.z;
    rayHit.ray.tnear = tnear;
    rayHit.ray.tfar = tfar;
    rayHit.ray.mask = 0xffffffffu;
    rayHit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(impl_->scene, &context, &rayHit);
    PrtHit hit;
    if (rayHit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return hit;
    const Triangle& tri = impl_->triangles[impl_->firstTriangle[rayHit.hit.geomID] + rayHit.hit.primID];
    hit.hit = true;
    hit.distance = rayHit.ray.tfar;
    hit.normal = tri.normal;
    hit.albedo = impl_->albedo[tri.instance];
    hit.frontFace = glm::dot(direction, tri.normal) < 0.0f;
    return hit;
}

bool PrtRayScene::occluded(const glm::vec3& from, const glm::vec3& to, float epsilon) const {
    const glm::vec3 d = to - from;
    const float length = glm::length(d);
    if (!(length > 2.0f * epsilon)) return false;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRay ray{};
    ray.org_x = from.x;
    ray.org_y = from.y;
    ray.org_z = from.z;
    ray.dir_x = d.x / length;
    ray.dir_y = d.y / length;
    ray.dir_z = d.z / length;
    ray.tnear = epsilon;
    ray.tfar = length - epsilon;
    ray.mask = 0xffffffffu;
    rtcOccluded1(impl_->scene, &context, &ray);
    return ray.tfar == -std::numeric_limits<float>::infinity();
}

const std::vector<PrtRayScene::Triangle>& PrtRayScene::triangles() const { return impl_->triangles; }
float PrtRayScene::diagonal() const { return impl_->diagonal; }
glm::vec3 PrtRayScene::averageAlbedo() const { return impl_->averageAlbedo; }

} // namespace lightskin::gi::detail
