#include <lightskin/core/Error.h>
#include <lightskin/gi/common/TriangleRayScene.h>

#include <embree3/rtcore.h>
#include <glm/geometric.hpp>

#include <limits>
#include <vector>

namespace lightskin::gi {

struct TriangleRayScene::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    std::vector<std::size_t> meshOfGeometry; ///< Embree geometry id -> index of create()'s meshes
    ~Impl() {
        if (scene) rtcReleaseScene(scene);
        if (device) rtcReleaseDevice(device);
    }
};

namespace {

void throwIfEmbreeError(RTCDevice device, const std::string& owner, const char* what) {
    const RTCError error = rtcGetDeviceError(device);
    if (error != RTC_ERROR_NONE)
        throw Error("embree", std::nullopt,
                    owner + ": " + what + " failed (RTCError " + std::to_string(int(error)) + ")");
}

void setRay(RTCRay& ray, const glm::dvec3& origin, const glm::dvec3& direction, double tNear, double tFar) {
    ray.org_x = float(origin.x);
    ray.org_y = float(origin.y);
    ray.org_z = float(origin.z);
    ray.dir_x = float(direction.x);
    ray.dir_y = float(direction.y);
    ray.dir_z = float(direction.z);
    ray.tnear = float(tNear);
    ray.tfar = float(tFar);
    ray.mask = 0xffffffffu;
    ray.time = 0.0f;
}

// Embree 3 with TBB turns a thread count into a process-wide tbb::global_control(max_allowed_parallelism, n)
// while the device lives (RenderKit/embree#507): "threads=1" would run every TBB loop of the process (OpenCV's
// parallel_for, the CPU backend) on one thread, making the replays 25-30 % slower. So Embree shares TBB's
// threads, except under ThreadSanitizer: Debian's libtbb is not instrumented, TSan cannot follow the hand-overs
// of Embree's parallel BVH build and of OpenCV's loops and reports them as races, so that build keeps those
// libraries' work on one thread.
#if defined(__SANITIZE_THREAD__)
#define LIGHTSKIN_UNDER_THREAD_SANITIZER
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define LIGHTSKIN_UNDER_THREAD_SANITIZER
#endif
#endif
#ifdef LIGHTSKIN_UNDER_THREAD_SANITIZER
constexpr const char* kEmbreeDeviceConfig = "threads=1";
#else
constexpr const char* kEmbreeDeviceConfig = nullptr;
#endif

} // namespace

TriangleRayScene::TriangleRayScene() = default;
TriangleRayScene::~TriangleRayScene() = default;
TriangleRayScene::TriangleRayScene(TriangleRayScene&&) noexcept = default;
TriangleRayScene& TriangleRayScene::operator=(TriangleRayScene&&) noexcept = default;

TriangleRayScene TriangleRayScene::create(std::span<const RayMesh> meshes, const std::string& owner,
                                          BuildQuality quality) {
    TriangleRayScene out;
    out.impl_ = std::make_unique<Impl>();
    Impl& impl = *out.impl_;
    impl.device = rtcNewDevice(kEmbreeDeviceConfig);
    if (!impl.device) throw Error("embree", std::nullopt, owner + ": rtcNewDevice failed");
    impl.scene = rtcNewScene(impl.device);
    rtcSetSceneFlags(impl.scene, RTC_SCENE_FLAG_ROBUST);
    if (quality == BuildQuality::High) rtcSetSceneBuildQuality(impl.scene, RTC_BUILD_QUALITY_HIGH);
    for (std::size_t m = 0; m < meshes.size(); ++m) {
        LIGHTSKIN_ASSERT(meshes[m].mesh != nullptr,
                         "lightskin::gi::TriangleRayScene::create(): RayMesh without a mesh");
        const TriangleMesh& mesh = *meshes[m].mesh;
        if (mesh.triangleCount() == 0) continue;
        RTCGeometry geometry = rtcNewGeometry(impl.device, RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
            geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), mesh.vertexCount()));
        auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
            geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), mesh.triangleCount()));
        if (vertices == nullptr || indices == nullptr) {
            rtcReleaseGeometry(geometry);
            throwIfEmbreeError(impl.device, owner, "creating geometry buffers"); // names Embree's error code
            throw Error("embree", std::nullopt, owner + ": creating geometry buffers failed");
        }
        for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
            const glm::dvec3 p(meshes[m].world_T_model * glm::dvec4(glm::dvec3(mesh.positions[v]), 1.0));
            for (int k = 0; k < 3; ++k) vertices[3 * v + std::size_t(k)] = float(p[k]);
        }
        for (std::size_t i = 0; i < mesh.indices.size(); ++i) indices[i] = mesh.indices[i];
        rtcCommitGeometry(geometry);
        impl.meshOfGeometry.push_back(m);
        rtcAttachGeometry(impl.scene, geometry); // ids 0, 1, ... in attach order (meshOfGeometry's index)
        rtcReleaseGeometry(geometry);
    }
    rtcCommitScene(impl.scene);
    throwIfEmbreeError(impl.device, owner, "building the scene");
    return out;
}

void TriangleRayScene::place(std::span<const RayMesh> meshes, const std::string& owner) {
    LIGHTSKIN_ASSERT(impl_, "lightskin::gi::TriangleRayScene::place(): used before create()");
    for (std::size_t id = 0; id < impl_->meshOfGeometry.size(); ++id) {
        const RayMesh& m = meshes[impl_->meshOfGeometry[id]];
        RTCGeometry geometry = rtcGetGeometry(impl_->scene, unsigned(id));
        auto* vertices = static_cast<float*>(rtcGetGeometryBufferData(geometry, RTC_BUFFER_TYPE_VERTEX, 0));
        for (std::size_t v = 0; v < m.mesh->vertexCount(); ++v) {
            const glm::dvec3 p(m.world_T_model * glm::dvec4(glm::dvec3(m.mesh->positions[v]), 1.0));
            for (int k = 0; k < 3; ++k) vertices[3 * v + std::size_t(k)] = float(p[k]);
        }
        rtcUpdateGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0);
        rtcCommitGeometry(geometry);
    }
    rtcCommitScene(impl_->scene);
    throwIfEmbreeError(impl_->device, owner, "rebuilding the scene");
}

bool TriangleRayScene::occluded(const glm::dvec3& origin, const glm::dvec3& direction, double tNear,
                                double tFar) const {
    LIGHTSKIN_ASSERT(impl_, "lightskin::gi::TriangleRayScene::occluded(): used before create()");
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRay ray{};
    setRay(ray, origin, direction, tNear, tFar);
    rtcOccluded1(impl_->scene, &context, &ray);
    return ray.tfar == -std::numeric_limits<float>::infinity(); // Embree's mark of a hit
}

bool TriangleRayScene::segmentOccluded(const glm::dvec3& from, const glm::dvec3& to, double epsilon) const {
    const glm::dvec3 d = to - from;
    const double length = glm::length(d);
    if (!(length > 2.0 * epsilon)) return false;
    // A unit direction makes tNear / tFar the epsilon in metres, whatever the segment's length.
    return occluded(from, d / length, epsilon, length - epsilon);
}

std::optional<RayHit> TriangleRayScene::intersect(const glm::dvec3& origin, const glm::dvec3& direction, double tNear,
                                                  double tFar) const {
    LIGHTSKIN_ASSERT(impl_, "lightskin::gi::TriangleRayScene::intersect(): used before create()");
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit hit{};
    setRay(hit.ray, origin, direction, tNear, tFar);
    hit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(impl_->scene, &context, &hit);
    if (hit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
    return RayHit{impl_->meshOfGeometry[hit.hit.geomID], hit.hit.primID, double(hit.hit.u), double(hit.hit.v),
                  double(hit.ray.tfar)};
}

} // namespace lightskin::gi
