// The synthetic scene of `lightskin bench` (see BenchScene.h).
#include <lightskin/bench/BenchScene.h>
#include <lightskin/core/Error.h>
#include <lightskin/gi/common/SparsePointSampler.h>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <numbers>
#include <sstream>

namespace lightskin::bench {

namespace {

struct Hit {
    double t = std::numeric_limits<double>::infinity();
    glm::dvec3 albedo{0.0}; // sRGB-encoded 0..1
};

// sRGB colours (encoded) of the room's surfaces.
constexpr glm::dvec3 kLeftWall{0.62, 0.25, 0.20};  // x = -1.6, reddish
constexpr glm::dvec3 kRightWall{0.25, 0.52, 0.30}; // x = +1.6, greenish
constexpr glm::dvec3 kBackWall{0.55, 0.55, 0.52};  // y = 2.2
constexpr glm::dvec3 kFrontWall{0.45, 0.45, 0.45}; // y = -1.0
constexpr glm::dvec3 kFloor{0.50, 0.42, 0.34};     // z = 0
constexpr glm::dvec3 kCeiling{0.60, 0.60, 0.60};   // z = 2.4
constexpr glm::dvec3 kBox{0.30, 0.35, 0.65};       // the real box, bluish
constexpr glm::dvec3 kRoomLo{-1.6, -1.0, 0.0}, kRoomHi{1.6, 2.2, 2.4};
constexpr glm::dvec3 kBoxLo{0.65, 0.95, 0.0}, kBoxHi{1.15, 1.45, 0.6};

Hit castRoom(const glm::dvec3& o, const glm::dvec3& d, double spotX) {
    Hit hit;
    // Interior of the room: the exit point is the nearest plane in the ray's direction per axis.
    const glm::dvec3 colourLo[3] = {kLeftWall, kFrontWall, kFloor};
    const glm::dvec3 colourHi[3] = {kRightWall, kBackWall, kCeiling};
    for (int a = 0; a < 3; ++a) {
        if (std::abs(d[a]) < 1e-12) continue;
        const double t = ((d[a] > 0 ? kRoomHi[a] : kRoomLo[a]) - o[a]) / d[a];
        if (t > 0 && t < hit.t) {
            hit.t = t;
            hit.albedo = d[a] > 0 ? colourHi[a] : colourLo[a];
        }
    }
    if (hit.albedo == kBackWall) {
        const glm::dvec3 p = o + hit.t * d;
        const double r = std::hypot(p.x - spotX, p.z - 1.3);
        if (r < 0.3) hit.albedo = glm::dvec3(1.0, 1.0, 0.95);
    }
    // The real box (slab test).
    double tNear = 0.0, tFar = hit.t;
    for (int a = 0; a < 3; ++a) {
        if (std::abs(d[a]) < 1e-12) {
            if (o[a] < kBoxLo[a] || o[a] > kBoxHi[a]) return hit;
            continue;
        }
        double t0 = (kBoxLo[a] - o[a]) / d[a], t1 = (kBoxHi[a] - o[a]) / d[a];
        if (t0 > t1) std::swap(t0, t1);
        tNear = std::max(tNear, t0);
        tFar = std::min(tFar, t1);
    }
    if (tNear < tFar && tNear > 0) {
        hit.t = tNear;
        hit.albedo = kBox;
    }
    return hit;
}

} // namespace

CameraIntrinsics depthIntrinsics() {
    CameraIntrinsics K;
    K.width = 640;
    K.height = 480;
    K.fx = K.fy = 525.0;
    K.cx = 319.5;
    K.cy = 239.5;
    return K;
}

Pose lookAtPose(const glm::dvec3& eye, const glm::dvec3& target) {
    const glm::dvec3 f = glm::normalize(target - eye);
    const glm::dvec3 r = glm::normalize(glm::cross(f, glm::dvec3(0, 0, 1)));
    const glm::dvec3 down = glm::cross(f, r);
    glm::dmat4 m(1.0);
    m[0] = glm::dvec4(r, 0.0);
    m[1] = glm::dvec4(down, 0.0);
    m[2] = glm::dvec4(f, 0.0);
    m[3] = glm::dvec4(eye, 1.0);
    return Pose::fromMatrix(m);
}

Pose depthCameraPose(double shift) {
    return lookAtPose(glm::dvec3(0.15 + shift, -0.85, 1.35), glm::dvec3(0.0 + shift, 1.6, 0.6));
}

void renderRoom(const CameraIntrinsics& K, const Pose& world_T_camera, double spotX, cv::Mat& depth,
                cv::Mat& colourBgr) {
    depth.create(K.height, K.width, CV_32FC1);
    colourBgr.create(K.height, K.width, CV_8UC3);
    const glm::dmat4 m = world_T_camera.matrix();
    const glm::dvec3 origin(m[3]);
    const glm::dmat3 rotation(m);
    for (int v = 0; v < K.height; ++v)
        for (int u = 0; u < K.width; ++u) {
            const glm::dvec3 rayCamera((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
            const Hit hit = castRoom(origin, rotation * rayCamera, spotX);
            depth.at<float>(v, u) = float(hit.t); // ray z = 1: t is the depth along the axis
            const auto encode = [](double x) { return cv::saturate_cast<std::uint8_t>(255.0 * x + 0.5); };
            colourBgr.at<cv::Vec3b>(v, u) = cv::Vec3b(encode(hit.albedo.b), encode(hit.albedo.g), encode(hit.albedo.r));
        }
}

TriangleMesh uvSphere(float radius, std::size_t triangles) {
    // stacks x slices quads (slices = 2 stacks) make 2 stacks slices triangles.
    const int stacks = std::max(4, int(std::lround(std::sqrt(double(triangles) / 4.0))));
    const int slices = 2 * stacks;
    TriangleMesh mesh;
    const double pi = std::numbers::pi;
    for (int i = 0; i <= stacks; ++i)
        for (int j = 0; j <= slices; ++j) {
            const double theta = pi * i / stacks, phi = 2.0 * pi * j / slices;
            const glm::vec3 n(float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)),
                              float(std::cos(theta)));
            mesh.positions.push_back(radius * n);
            mesh.normals.push_back(n);
        }
    for (int i = 0; i < stacks; ++i)
        for (int j = 0; j < slices; ++j) {
            const auto a = std::uint32_t(i * (slices + 1) + j), b = a + std::uint32_t(slices + 1);
            mesh.indices.insert(mesh.indices.end(), {a, b, b + 1, a, b + 1, a + 1});
        }
    return mesh;
}

TriangleMesh bunny(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw Error(path, std::nullopt, "cannot open the bunny PLY (--bunny)");
    std::string line;
    std::size_t vertices = 0, faces = 0;
    while (std::getline(in, line)) {
        std::istringstream words(line);
        std::string a, b;
        words >> a >> b;
        if (a == "element" && b == "vertex") words >> vertices;
        if (a == "element" && b == "face") words >> faces;
        if (a == "end_header") break;
    }
    if (vertices == 0 || faces == 0 || vertices > 10'000'000 || faces > 10'000'000)
        throw Error(path, std::nullopt, "not an ASCII PLY with vertices and faces");
    TriangleMesh mesh;
    for (std::size_t i = 0; i < vertices && std::getline(in, line); ++i) {
        std::istringstream words(line);
        double x = 0, y = 0, z = 0;
        words >> x >> y >> z;
        mesh.positions.emplace_back(float(x), float(-z), float(y)); // Y up -> Z up
    }
    for (std::size_t i = 0; i < faces && std::getline(in, line);) {
        if (line.rfind("comment", 0) == 0) continue; // the zipper file has commented-out faces
        std::istringstream words(line);
        std::size_t n = 0;
        words >> n;
        std::uint32_t f[3] = {0, 0, 0};
        if (n != 3 || !(words >> f[0] >> f[1] >> f[2]))
            throw Error(path, std::nullopt, "face " + std::to_string(i) + " is not a triangle");
        mesh.indices.insert(mesh.indices.end(), {f[0], f[1], f[2]});
        ++i;
    }
    if (mesh.positions.size() != vertices || mesh.indices.size() != 3 * faces)
        throw Error(path, std::nullopt, "truncated PLY");
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (const auto& p : mesh.positions) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    const float scale = 0.45f / (hi.z - lo.z);
    const glm::vec3 base(0.5f * (lo.x + hi.x), 0.5f * (lo.y + hi.y), lo.z);
    for (auto& p : mesh.positions) p = scale * (p - base);
    mesh.computeVertexNormals();
    mesh.validate(path);
    gi::refineMeshToEdgeLength(mesh, 1e-4, 16000);
    return mesh;
}

glm::mat4 sphereWorld() { return glm::translate(glm::mat4(1.0f), {-0.35f, 1.0f, 0.3f}); }
glm::mat4 bunnyWorld() {
    return glm::rotate(glm::translate(glm::mat4(1.0f), {0.3f, 0.75f, 0.0f}), 0.5f, glm::vec3(0, 0, 1));
}

Material sphereMaterial() {
    Material m;
    m.diffuseAlbedo = glm::vec3(0.7f, 0.7f, 0.7f);
    m.specularAlbedo = glm::vec3(0.25f);
    m.specularExponent = 20.0f;
    return m;
}

Material bunnyMaterial() {
    Material m;
    m.diffuseAlbedo = glm::vec3(0.75f, 0.7f, 0.6f);
    return m;
}

glm::vec3 viewEye(int t, int n) {
    const float phase = n > 1 ? float(t) / float(n - 1) : 0.0f;
    return {-0.45f + 0.6f * phase, -0.35f, 1.05f - 0.1f * phase};
}

glm::vec3 viewTarget() { return {-0.05f, 0.9f, 0.28f}; }

glm::mat4 viewClip(int width, int height, int t, int n) {
    const glm::mat4 projection = glm::perspective(0.75f, float(width) / float(height), 0.05f, 20.0f);
    return projection * glm::lookAt(viewEye(t, n), viewTarget(), glm::vec3(0, 0, 1));
}

TriangleMesh grid(float size, int cells) {
    TriangleMesh mesh;
    for (int i = 0; i <= cells; ++i)
        for (int j = 0; j <= cells; ++j) {
            mesh.positions.emplace_back(size * (float(j) / float(cells) - 0.5f),
                                        size * (float(i) / float(cells) - 0.5f), 0.0f);
            mesh.normals.emplace_back(0.0f, 0.0f, 1.0f);
        }
    for (int i = 0; i < cells; ++i)
        for (int j = 0; j < cells; ++j) {
            const auto a = std::uint32_t(i * (cells + 1) + j), b = a + std::uint32_t(cells + 1);
            mesh.indices.insert(mesh.indices.end(), {a, a + 1, b + 1, a, b + 1, b});
        }
    return mesh;
}

/// A width x height VAL map: half on a wall (x = -1.2, facing +x), half on the ceiling.
std::vector<gi::VirtualAreaLight> valMap(int width, int height) {
    std::vector<gi::VirtualAreaLight> vals;
    vals.reserve(std::size_t(width) * std::size_t(height));
    const float pi = std::numbers::pi_v<float>;
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            const float u = (float(x) + 0.5f) / float(width), v = (float(y) + 0.5f) / float(height);
            gi::VirtualAreaLight l;
            const glm::vec3 colour(0.6f + 0.4f * std::sin(7.0f * u), 0.5f + 0.3f * std::cos(5.0f * v), 0.4f + 0.2f * u);
            if (y < height / 2) {
                const float vv = v * 2.0f;
                l.position = {-1.2f, 2.4f * (u - 0.5f), 1.6f * vv};
                l.normal = {1.0f, 0.0f, 0.0f};
                l.area = (2.4f / float(width)) * (1.6f / float(height / 2));
            } else {
                const float vv = (v - 0.5f) * 2.0f;
                l.position = {2.4f * (u - 0.5f), 2.4f * (vv - 0.5f), 1.8f};
                l.normal = {0.0f, 0.0f, -1.0f};
                l.area = (2.4f / float(width)) * (2.4f / float(height - height / 2));
            }
            l.flux = pi * 0.5f * colour * l.area;
            vals.push_back(l);
        }
    return vals;
}

std::pair<int, int> parseValMapSize(const std::string& text) {
    int width = 0, height = 0;
    if (std::sscanf(text.c_str(), "%dx%d", &width, &height) != 2 || width <= 0 || height <= 1)
        throw Error("--vals", std::nullopt, "expected WIDTHxHEIGHT, got '" + text + "'");
    return {width, height};
}

GatherScene gatherScene(int width, int height) {
    std::vector<TriangleMesh> meshes{uvSphere(0.4f, 4 * 64 * 64), grid(2.4f, 64)}; // 64 stacks x 128 slices
    std::vector<gi::UploadedMesh> gpu;
    std::vector<gi::MeshInstance> instances(2);
    for (std::size_t i = 0; i < 2; ++i) {
        gpu.push_back(gi::UploadedMesh::create(meshes[i]));
        instances[i].meshId = std::uint32_t(i);
        instances[i].mesh = &meshes[i];
        instances[i].gpu = gpu[i].view();
    }
    instances[0].world_T_model = glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, 0.55f});
    instances[0].material.specularAlbedo = glm::vec3(0.3f);
    instances[0].material.specularExponent = 30.0f;
    instances[1].material.diffuseAlbedo = glm::vec3(0.6f);
    const glm::vec3 eye(1.8f, -2.0f, 1.6f);
    const glm::mat4 projection = glm::perspective(0.8f, float(width) / float(height), 0.05f, 50.0f);
    const gi::ViewParameters view{projection * glm::lookAt(eye, glm::vec3(0.0f, 0.0f, 0.4f), glm::vec3(0, 0, 1)), eye};
    gi::SimpleGBuffer gbuffer = gi::SimpleGBuffer::create(width, height);
    gbuffer.render(instances, view.clip_T_world);
    return {std::move(meshes), std::move(gpu), std::move(instances), view, std::move(gbuffer)};
}

} // namespace lightskin::bench
