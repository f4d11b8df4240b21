// `lightskin bench-static`: the adaptive mode's static-content reuse (LightSkinSettings::reuseStatic,
// staticTolerance) side by side with full recomputation, in one run, on three input streams:
//   repeat  the synthetic room of `lightskin bench` (BenchScene.h), the identical frame every time
//           (a still camera with a noise-free sensor: exact reuse);
//   noise   the same frame with fresh Kinect v1 axial noise sigma_z(z) = 0.0012 + 0.0019 (z - 0.4)^2 m
//           per pixel and frame (render::kinectAxialNoiseMetres, Nguyen et al. 2012), bilateral
//           filtered like the replay (a still camera with a real sensor's depth noise);
//   real    (with --recording) consecutive frames of a real recording, camera pose fixed (identity),
//           ping-pong order; a sphere is placed in front of the camera.
// Every stream's frames go through one ValGenerator (skipUnchangedInput) and then through one
// LightSkin instance per mode: "full" (adaptive, reuseStatic off: the reference), "exact"
// (staticTolerance 0), "bound, tolerance <tau>" (StaticChangeTest::Bound, keyed by the depth pixel)
// and "probes 1/<n>, tolerance <tau>" (StaticChangeTest::Probes). Per mode: reuse rate, mean GPU time of the
// technique's stages, and the image error against "full" of the same frame (max |a - b| / max b and mean |a - b| / mean
// b over covered pixels). Materials are made diffuse with --diffuse (the tolerance mode needs the glossy channel off).
#include <lightskin/bench/BenchScene.h>
#include <lightskin/bench/StaticBench.h>
#include <lightskin/bench/StopRequest.h>
#include <lightskin/capture/DepthFilter.h>
#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>
#include <lightskin/gi/lightskin/LightSkinIllumination.h>
#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gi/common/SparsePointSampler.h>
#include <lightskin/gi/common/ValGenerator.h>
#include <lightskin/gl/Context.h>
#include <lightskin/gl/Objects.h>
#include <lightskin/render/Compositor.h>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace lightskin::bench {

namespace {

struct Mode {
    std::string name;
    gi::LightSkinSettings settings;
    std::unique_ptr<gi::LightSkinIllumination> technique;
    int reused = 0, frames = 0;
    double gpuMs = 0.0, maxError = 0.0, meanErrorSum = 0.0, boundSum = 0.0;
    int bounds = 0;
};

struct Stream {
    std::string name;
    std::vector<gi::MeshInstance> instances;
    glm::mat4 clip{1.0f};
    glm::vec3 eye{0.0f};
    CameraIntrinsics K;
    Pose world_T_camera;
    /// Fills depth (metres, CV_32FC1) and colour (CV_8UC3) of frame t.
    std::function<void(int t, cv::Mat& depth, cv::Mat& colour)> frame;
};

struct Meshes {
    std::vector<std::unique_ptr<TriangleMesh>> meshes;
    std::vector<std::unique_ptr<gi::UploadedMesh>> gpu;
    std::map<const TriangleMesh*, gi::SparsePointSet> sparse;

    gi::MeshInstance add(TriangleMesh mesh, std::uint32_t id, const glm::mat4& world_T_model,
                         const Material& material) {
        meshes.push_back(std::make_unique<TriangleMesh>(std::move(mesh)));
        gpu.push_back(std::make_unique<gi::UploadedMesh>(gi::UploadedMesh::create(*meshes.back())));
        gi::MeshInstance instance;
        instance.meshId = id;
        instance.mesh = meshes.back().get();
        instance.gpu = gpu.back()->view();
        instance.world_T_model = world_T_model;
        instance.material = material;
        return instance;
    }
    gi::SparsePointProvider provider(int count) {
        return [this, count](const gi::MeshInstance& instance) {
            auto it = sparse.find(instance.mesh);
            if (it == sparse.end()) {
                gi::SparsePointSettings s;
                s.pointCount = count;
                it = sparse.emplace(instance.mesh, gi::sampleSparsePoints(*instance.mesh, s, "bench mesh")).first;
            }
            return it->second;
        };
    }
};

Material maybeDiffuse(Material m, bool diffuse) {
    if (diffuse) m.specularAlbedo = glm::vec3(0.0f);
    return m;
}

cv::Mat readRgba(std::uint32_t texture, int width, int height) {
    cv::Mat image(height, width, CV_32FC4);
    glGetTextureImage(texture, 0, GL_RGBA, GL_FLOAT, GLsizei(image.total() * image.elemSize()), image.data);
    return image;
}

/// Runs every mode on the stream and prints its table; a stop ends it after the current frame, the table then
/// over the frames measured (none: no table).
void runStream(const Stream& stream, const StaticBenchOptions& o, Meshes& meshes, std::vector<Mode>& modes,
               StopCheck& stop) {
    gi::ValGeneratorSettings vs;
    vs.stride = o.stride;
    vs.exposure = 2.0f;
    vs.skipUnchangedInput = true;
    gi::ValGenerator generator = gi::ValGenerator::create(stream.K.width, stream.K.height, vs);
    gi::SimpleGBuffer gbuffer = gi::SimpleGBuffer::create(o.width, o.height);
    gl::Texture target = gl::Texture::create2D(GL_RGBA32F, o.width, o.height);
    gbuffer.render(stream.instances, stream.clip);
    const cv::Mat position = readRgba(gbuffer.position().id(), o.width, o.height);
    for (Mode& m : modes) {
        m.technique = gi::LightSkinIllumination::create(m.settings, meshes.provider(o.sparse));
        m.technique->prepare(stream.instances);
        m.reused = m.frames = m.bounds = 0;
        m.gpuMs = m.maxError = m.meanErrorSum = m.boundSum = 0.0;
    }
    cv::Mat depth, colour, reference;
    std::vector<gl::StageTime> stages;
    int skipped = 0;
    std::uint32_t vals = 0;
    for (int t = 0; t <= o.frames && !stop(); ++t) { // t = 0: warm-up (first full computation), not counted
        stream.frame(t, depth, colour);
        const gi::ValSetView set = generator.generate(depth, 1.0, colour, stream.K, stream.world_T_camera);
        vals = set.count;
        if (t > 0 && generator.lastSkipped()) ++skipped;
        for (Mode& m : modes) {
            m.technique->render(set, stream.instances, gbuffer.view(), {stream.clip, stream.eye}, target.id());
            m.technique->lastStageTimes(stages);
            const cv::Mat image = readRgba(target.id(), o.width, o.height);
            if (&m == &modes.front()) reference = image.clone();
            if (t == 0) continue;
            double total = 0.0;
            for (const auto& s : stages) total += s.milliseconds;
            m.gpuMs += total;
            ++m.frames;
            if (m.technique->lastChoice().reused) ++m.reused;
            if (m.technique->lastChoice().staticChangeBound >= 0.0f) {
                m.boundSum += double(m.technique->lastChoice().staticChangeBound);
                ++m.bounds;
            }
            double largest = 0.0, worst = 0.0, sumDiff = 0.0, sumRef = 0.0;
            for (int y = 0; y < o.height; ++y)
                for (int x = 0; x < o.width; ++x) {
                    if (position.at<cv::Vec4f>(y, x)[3] == 0.0f) continue;
                    const cv::Vec4f a = image.at<cv::Vec4f>(y, x), b = reference.at<cv::Vec4f>(y, x);
                    for (int c = 0; c < 3; ++c) {
                        largest = std::max(largest, double(b[c]));
                        worst = std::max(worst, double(std::abs(a[c] - b[c])));
                        sumDiff += double(std::abs(a[c] - b[c]));
                        sumRef += double(std::abs(b[c]));
                    }
                }
            m.maxError = std::max(m.maxError, largest > 0.0 ? worst / largest : 0.0);
            m.meanErrorSum += sumRef > 0.0 ? sumDiff / sumRef : 0.0;
        }
    }
    const int frames = modes.front().frames;
    if (frames == 0) return; // stopped in the warm-up
    std::printf("\n### stream %s: %d frames, %u VALs (stride %d), %d sparse points per object, %dx%d, "
                "ValGenerator skipped %d of %d passes\n\n",
                stream.name.c_str(), frames, vals, o.stride, o.sparse, o.width, o.height, skipped, frames);
    std::printf("| mode | reused | GI GPU ms/frame | speed-up vs full | max image error | mean image error | mean "
                "change measure |\n");
    std::printf("|---|---|---|---|---|---|---|\n");
    const double fullMs = modes.front().gpuMs / std::max(1, modes.front().frames);
    for (const Mode& m : modes) {
        const double ms = m.gpuMs / std::max(1, m.frames);
        char bound[32] = "-";
        if (m.bounds > 0) std::snprintf(bound, sizeof bound, "%.3g", m.boundSum / m.bounds);
        std::printf("| %s | %d/%d | %.1f | %.2fx | %.2e | %.2e | %s |\n", m.name.c_str(), m.reused, m.frames, ms,
                    ms > 0.0 ? fullMs / ms : 0.0, m.maxError, m.meanErrorSum / std::max(1, m.frames), bound);
    }
    std::fflush(stdout);
}

} // namespace

void runStaticBench(const StaticBenchOptions& o) {
    StopCheck stop(o.stopRequested);
    auto context = gl::createHeadlessContext();
    std::vector<Mode> modes;
    const auto addMode = [&](std::string name, bool reuse, float tolerance,
                             gi::StaticChangeTest test = gi::StaticChangeTest::Bound) {
        Mode m;
        m.name = std::move(name);
        m.settings.adaptive = true;
        m.settings.reuseStatic = reuse;
        m.settings.staticTolerance = tolerance;
        m.settings.staticChangeTest = test;
        m.settings.staticProbeStride = o.probeStride;
        m.settings.kCache = 128;
        modes.push_back(std::move(m));
    };
    addMode("full (adaptive, reuseStatic off)", false, 0.0f);
    addMode("exact (staticTolerance 0)", true, 0.0f);
    const auto tolerances = bench::splitList<float>(o.tolerances, [](const std::string& x) { return std::stof(x); });
    for (float tau : tolerances) {
        char name[48];
        std::snprintf(name, sizeof name, "bound, tolerance %.3g", double(tau));
        addMode(name, true, tau);
    }
    for (float tau : tolerances) {
        char name[48];
        std::snprintf(name, sizeof name, "probes 1/%d, tolerance %.3g", o.probeStride, double(tau));
        addMode(name, true, tau, gi::StaticChangeTest::Probes);
    }

    Meshes meshes;
    // Synthetic room (BenchScene.h): the glossy sphere and the bunny on the floor.
    Stream room;
    room.K = bench::depthIntrinsics();
    room.world_T_camera = bench::depthCameraPose();
    room.instances.push_back(meshes.add(bench::uvSphere(0.3f, 20000), 1, bench::sphereWorld(),
                                        maybeDiffuse(bench::sphereMaterial(), o.diffuse)));
    room.instances.push_back(
        meshes.add(bench::bunny(o.bunnyPath), 2, bench::bunnyWorld(), maybeDiffuse(bench::bunnyMaterial(), o.diffuse)));
    room.clip = bench::viewClip(o.width, o.height);
    room.eye = bench::viewEye();
    cv::Mat roomDepth, roomColour;
    bench::renderRoom(room.K, room.world_T_camera, 0.0, roomDepth, roomColour);
    std::printf("## lightskin bench-static (%s materials)\n", o.diffuse ? "diffuse" : "scene");
    std::fflush(stdout);

    room.name = "repeat (synthetic room, identical frames)";
    room.frame = [&](int, cv::Mat& depth, cv::Mat& colour) {
        depth = roomDepth;
        colour = roomColour;
    };
    runStream(room, o, meshes, modes, stop);
    if (stop()) return printInterrupted("bench-static");

    capture::BilateralDepthFilter filter;
    cv::Mat noisy, filtered;
    cv::RNG random(o.seed);
    room.name = "noise (synthetic room, Kinect v1 axial noise per frame, bilateral filtered)";
    room.frame = [&](int, cv::Mat& depth, cv::Mat& colour) {
        roomDepth.copyTo(noisy);
        for (int y = 0; y < noisy.rows; ++y)
            for (int x = 0; x < noisy.cols; ++x) {
                float& z = noisy.at<float>(y, x);
                if (z > 0.0f) z += float(random.gaussian(double(render::kinectAxialNoiseMetres(z))));
            }
        filter.filterInto(noisy, 1.0, filtered);
        depth = filtered;
        colour = roomColour;
    };
    runStream(room, o, meshes, modes, stop);
    if (stop()) return printInterrupted("bench-static");

    if (!o.recording.empty()) {
        auto source = capture::openFrameSource(o.recording);
        std::vector<cv::Mat> depths, colours;
        RgbdFrame frame;
        while (source->next(frame)) {
            if (frame.depth.empty() || frame.colour.empty() || frame.depth.size() != frame.colour.size()) continue;
            cv::Mat metres;
            filter.filterInto(frame.depth, frame.depthScaleMetres, metres);
            depths.push_back(metres.clone());
            colours.push_back(frame.colour.clone());
        }
        if (depths.size() < 2)
            throw Error(o.recording, std::nullopt, "needs at least two frames with depth and colour");
        Stream real;
        real.name = "real (" + o.recording + ", " + std::to_string(depths.size()) + " frames ping-pong, pose fixed)";
        real.K = source->info().colourIntrinsics;
        // the median depth of the central quarter; a sphere of 0.15 m radius 0.3 m in front of it
        std::vector<float> centre;
        const cv::Mat& d0 = depths.front();
        for (int y = d0.rows * 3 / 8; y < d0.rows * 5 / 8; ++y)
            for (int x = d0.cols * 3 / 8; x < d0.cols * 5 / 8; ++x)
                if (d0.at<float>(y, x) > 0.0f) centre.push_back(d0.at<float>(y, x));
        if (centre.empty()) throw Error(o.recording, 0, "no depth in the image centre");
        std::nth_element(centre.begin(), centre.begin() + std::ptrdiff_t(centre.size() / 2), centre.end());
        const float z = std::max(0.6f, centre[centre.size() / 2] - 0.3f);
        Material material;
        material.diffuseAlbedo = glm::vec3(0.8f);
        real.instances.push_back(
            meshes.add(bench::uvSphere(0.15f, 20000), 3, glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, z}), material));
        const float fovY = 2.0f * std::atan(0.5f * float(real.K.height) / float(std::abs(real.K.fy)));
        real.clip = glm::perspective(fovY, float(o.width) / float(o.height), 0.05f, 20.0f) *
                    glm::lookAt(glm::vec3(0.0f), glm::vec3(0, 0, 1), glm::vec3(0, -1, 0));
        real.frame = [&](int t, cv::Mat& depth, cv::Mat& colour) {
            const int n = int(depths.size()), period = 2 * (n - 1);
            const int phase = t % period, i = phase < n ? phase : period - phase;
            depth = depths[std::size_t(i)];
            colour = colours[std::size_t(i)];
        };
        runStream(real, o, meshes, modes, stop);
    }
    if (stop()) printInterrupted("bench-static");
}

} // namespace lightskin::bench
