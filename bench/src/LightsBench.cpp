// `lightskin bench-lights`: times the light-side GI stages on this machine: VAL generation
// from a 640x480 depth frame for VAL maps 160x120 / 320x240 / 640x480 on the GPU (GL timer queries)
// and the double CPU reference, reflective-shadow-map VALs, and sparse-point preparation for
// 64..16k points on a ~70k-triangle mesh. Prints a markdown table (docs/BENCHMARKS.md).

#include <lightskin/bench/LightsBench.h>
#include <lightskin/bench/StopRequest.h>
#include <lightskin/core/Error.h>
#include <lightskin/gi/common/ReflectiveShadowMap.h>
#include <lightskin/gi/common/SparsePointSampler.h>
#include <lightskin/gi/common/ValGenerator.h>
#include <lightskin/gi/reference/ValGeneratorReference.h>
#include <lightskin/gl/Context.h>
#include <lightskin/gl/DebugOutput.h>
#include <lightskin/gl/GpuTimer.h>

#include <glm/geometric.hpp>
#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

namespace lightskin::bench {

namespace {

double median(std::vector<double> values) {
    std::sort(values.begin(), values.end());
    return values.empty() ? 0.0 : values[values.size() / 2];
}

double secondsSince(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// A 640x480 synthetic frame: a sphere in front of a floor and a wall, random colours.
void syntheticFrame(const CameraIntrinsics& K, cv::Mat& depth, cv::Mat& colour) {
    depth.create(K.height, K.width, CV_32FC1);
    colour.create(K.height, K.width, CV_8UC3);
    cv::randu(colour, 0, 255);
    const glm::dvec3 centre(0.1, 0.1, 1.5);
    const double radius = 0.35;
    for (int v = 0; v < K.height; ++v)
        for (int u = 0; u < K.width; ++u) {
            const glm::dvec3 ray((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
            double t = 3.0;                                    // wall at z = 3
            const double floorT = 0.8 / std::max(1e-9, ray.y); // floor y = 0.8 (y down)
            if (ray.y > 0 && floorT < t) t = floorT;
            const double b = glm::dot(ray, centre), a = glm::dot(ray, ray);
            const double disc = b * b - a * (glm::dot(centre, centre) - radius * radius);
            if (disc >= 0) t = std::min(t, (b - std::sqrt(disc)) / a);
            depth.at<float>(v, u) = float(t);
        }
}

// Minimal OBJ reader (v and triangular f lines; "a/b/c" keeps a).
TriangleMesh readObj(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw Error(path, std::nullopt, "cannot open the mesh");
    TriangleMesh mesh;
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream words(line);
        std::string tag;
        words >> tag;
        if (tag == "v") {
            glm::vec3 p;
            words >> p.x >> p.y >> p.z;
            mesh.positions.push_back(p);
        } else if (tag == "f") {
            std::vector<std::uint32_t> face;
            std::string corner;
            while (words >> corner) face.push_back(std::uint32_t(std::stoul(corner.substr(0, corner.find('/')))) - 1);
            for (std::size_t k = 1; k + 1 < face.size(); ++k)
                mesh.indices.insert(mesh.indices.end(), {face[0], face[k], face[k + 1]});
        }
    }
    mesh.computeVertexNormals();
    mesh.validate(path);
    return mesh;
}

TriangleMesh sphereMesh(int rings, int segments) {
    TriangleMesh mesh;
    for (int r = 0; r <= rings; ++r)
        for (int s = 0; s <= segments; ++s) {
            const double theta = std::numbers::pi * r / rings, phi = 2 * std::numbers::pi * s / segments;
            mesh.positions.push_back(0.1f * glm::vec3(float(std::sin(theta) * std::cos(phi)),
                                                      float(std::sin(theta) * std::sin(phi)), float(std::cos(theta))));
        }
    for (int r = 0; r < rings; ++r)
        for (int s = 0; s < segments; ++s) {
            const auto at = [&](int rr, int ss) { return std::uint32_t(rr * (segments + 1) + ss); };
            if (r != 0) mesh.indices.insert(mesh.indices.end(), {at(r, s), at(r + 1, s), at(r, s + 1)});
            if (r != rings - 1) mesh.indices.insert(mesh.indices.end(), {at(r, s + 1), at(r + 1, s), at(r + 1, s + 1)});
        }
    mesh.computeVertexNormals();
    return mesh;
}

} // namespace

void runLightsBench(const LightsBenchOptions& options) {
    StopCheck stop(options.stopRequested);
    auto context = gl::createHeadlessContext();
    std::ostringstream report;
    // Each row is printed once measured (a long run shows its progress, a stopped one keeps its rows); the whole
    // report goes to --out at the end.
    std::size_t printed = 0;
    const auto printNew = [&report, &printed] {
        const std::string text = report.str();
        std::fputs(text.c_str() + printed, stdout);
        std::fflush(stdout);
        printed = text.size();
    };
    const auto finish = [&] {
        gl::DebugOutput::throwIfErrors("bench-lights");
        if (stop()) report << "\n" << interruptedLine("bench-lights") << "\n";
        printNew();
        if (options.out.empty()) return;
        std::ofstream file(options.out);
        if (!(file << report.str())) throw Error(options.out, std::nullopt, "could not write the report");
    };
    report << "Renderer: " << context->describe() << "\n\n";
    report << "### VALs from a 640x480 depth frame (synthetic sphere, floor, wall), median of " << options.repeat
           << "\n\n| VAL map | stride | VALs | GPU upload ms | GPU pass ms | wall ms (upload + pass + count read-back) "
              "| CPU reference ms (PCL normals, double) |\n|---|---|---|---|---|---|---|\n";
    const CameraIntrinsics K = CameraIntrinsics::kinectV1Default();
    cv::Mat depth, colour;
    syntheticFrame(K, depth, colour);
    gl::GpuStageTimer timer = gl::GpuStageTimer::create(2);
    std::vector<gl::StageTime> stages;
    printNew();
    for (int stride : {4, 2, 1}) {
        if (stop()) break;
        gi::ValGeneratorSettings settings;
        settings.stride = stride;
        gi::ValGenerator generator = gi::ValGenerator::create(K.width, K.height, settings);
        generator.setStageTimer(&timer);
        std::vector<double> upload, gpu, wall, cpu;
        std::uint32_t count = 0;
        for (int i = 0; i < options.repeat + 2 && !stop(); ++i) {
            timer.beginFrame();
            const auto start = std::chrono::steady_clock::now();
            count = generator.generate(depth, 1.0, colour, K, Pose{}).count;
            const double seconds = secondsSince(start);
            timer.collect(stages);
            if (i >= 2)
                upload.push_back(stages[0].milliseconds), gpu.push_back(stages[1].milliseconds),
                    wall.push_back(seconds * 1e3);
        }
        for (int i = 0; i < std::max(1, options.repeat / 5) && !stop(); ++i) {
            const auto start = std::chrono::steady_clock::now();
            const auto reference = gi::generateValsReference(depth, 1.0, colour, K, Pose{}, settings);
            cpu.push_back(secondsSince(start) * 1e3);
        }
        if (stop.stopped()) break; // a row cut short is not shown: its median would be over fewer runs
        char row[256];
        std::snprintf(row, sizeof row, "| %dx%d | %d | %u | %.2f | %.2f | %.2f | %.1f |\n", K.width / stride,
                      K.height / stride, stride, count, median(upload), median(gpu), median(wall), median(cpu));
        report << row;
        printNew();
    }
    if (stop()) return finish();

    const TriangleMesh mesh = options.mesh.empty() ? sphereMesh(150, 234) : readObj(options.mesh);
    const std::string meshName = options.mesh.empty() ? "UV sphere r = 0.1 m" : options.mesh;
    report << "\n### Sparse-point preparation (refine + FPS + 8 neighbours + occluder radii), mesh " << meshName << ", "
           << mesh.triangleCount() << " triangles, " << mesh.vertexCount() << " vertices\n\n"
           << "| N | refined triangles | tessellation ratio | seconds |\n|---|---|---|---|\n";
    printNew();
    for (int n : {64, 256, 1024, 4096, 16384}) {
        if (stop()) return finish();
        TriangleMesh copy = mesh;
        gi::SparsePointSettings settings;
        settings.pointCount = n;
        const auto start = std::chrono::steady_clock::now();
        const gi::SparsePointSet set = gi::prepareSparsePoints(copy, settings, meshName);
        const double seconds = secondsSince(start);
        char row[256];
        std::snprintf(row, sizeof row, "| %d | %zu | %.2f | %.3f |\n", n, copy.triangleCount(),
                      double(set.tessellationRatio), seconds);
        report << row;
        printNew();
    }
    if (stop()) return finish();
    // RSM VALs: one spot light looking at the (unrefined) mesh from 3 bounding radii away.
    {
        glm::vec3 lo(1e30f), hi(-1e30f);
        for (const glm::vec3& p : mesh.positions) lo = glm::min(lo, p), hi = glm::max(hi, p);
        const glm::vec3 centre = 0.5f * (lo + hi);
        const float radius = 0.5f * glm::length(hi - lo);
        std::vector<float> interleaved;
        for (std::size_t i = 0; i < mesh.vertexCount(); ++i)
            interleaved.insert(interleaved.end(), {mesh.positions[i].x, mesh.positions[i].y, mesh.positions[i].z,
                                                   mesh.normals[i].x, mesh.normals[i].y, mesh.normals[i].z});
        gl::Buffer vertices = gl::Buffer::create(GLsizeiptr(interleaved.size() * sizeof(float)), interleaved.data(), 0);
        gl::Buffer indices =
            gl::Buffer::create(GLsizeiptr(mesh.indices.size() * sizeof(std::uint32_t)), mesh.indices.data(), 0);
        gl::VertexArray vertexArray = gl::VertexArray::create();
        glVertexArrayVertexBuffer(vertexArray.id(), 0, vertices.id(), 0, 6 * sizeof(float));
        glVertexArrayElementBuffer(vertexArray.id(), indices.id());
        for (GLuint attribute = 0; attribute < 2; ++attribute) {
            glEnableVertexArrayAttrib(vertexArray.id(), attribute);
            glVertexArrayAttribFormat(vertexArray.id(), attribute, 3, GL_FLOAT, GL_FALSE,
                                      attribute * 3 * sizeof(float));
            glVertexArrayAttribBinding(vertexArray.id(), attribute, 0);
        }
        gi::MeshInstance instance;
        instance.mesh = &mesh;
        instance.gpu = {vertexArray.id(), std::uint32_t(mesh.indices.size()), std::uint32_t(mesh.vertexCount())};
        gi::VirtualLight spot;
        spot.position = centre + glm::vec3(0.0f, 0.0f, 3.0f * radius);
        spot.direction = {0.0f, 0.0f, -1.0f};
        spot.spotHalfAngle = 0.4f;
        report << "\n### RSM VALs (one spot light on the mesh above), median of " << options.repeat
               << "\n\n| RSM resolution | VALs | GPU ms (raster + compaction) |\n|---|---|---|\n";
        printNew();
        for (int resolution : {64, 128, 256}) {
            if (stop()) break;
            gi::RsmSettings settings;
            settings.resolution = resolution;
            settings.maxLights = 1;
            gi::ReflectiveShadowMap rsm = gi::ReflectiveShadowMap::create(settings);
            std::vector<double> gpu;
            std::uint32_t count = 0;
            for (int i = 0; i < options.repeat + 2 && !stop(); ++i) {
                timer.beginFrame();
                timer.begin("rsm");
                count = rsm.generate(std::span(&spot, 1), std::span(&instance, 1)).count;
                timer.end();
                timer.collect(stages);
                if (i >= 2) gpu.push_back(stages[0].milliseconds);
            }
            if (stop.stopped()) break;
            char row[128];
            std::snprintf(row, sizeof row, "| %dx%d | %u | %.2f |\n", resolution, resolution, count, median(gpu));
            report << row;
            printNew();
        }
    }
    finish();
}

} // namespace lightskin::bench
