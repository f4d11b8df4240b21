#include <lightskin/core/Error.h>
#include <lightskin/synth/DepthNoise.h>
#include <lightskin/synth/Generator.h>

#include <opencv2/core.hpp>

#include <cmath>

namespace lightskin::synth {

std::uint8_t encodeSrgb(float linear) noexcept {
    const double x = std::clamp(double(linear), 0.0, 1.0);
    const double encoded = x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
    return std::uint8_t(std::lround(encoded * 255.0));
}

float decodeSrgb(std::uint8_t encoded) noexcept {
    const double x = double(encoded) / 255.0;
    return float(x <= 0.04045 ? x / 12.92 : std::pow((x + 0.055) / 1.055, 2.4));
}

void depthMetresToUnitsInto(const cv::Mat& metres, double scaleMetres, cv::Mat& units) {
    LIGHTSKIN_ASSERT(metres.type() == CV_32FC1 && scaleMetres > 0.0, "lightskin::synth::depthMetresToUnitsInto(): bad input");
    units.create(metres.size(), CV_16UC1);
    for (int v = 0; v < metres.rows; ++v) {
        const float* in = metres.ptr<float>(v);
        std::uint16_t* out = units.ptr<std::uint16_t>(v);
        for (int u = 0; u < metres.cols; ++u) {
            const double value = std::round(double(in[u]) / scaleMetres);
            out[u] = in[u] > 0.0f && value <= 65535.0 ? std::uint16_t(value) : std::uint16_t(0);
        }
    }
}

Generator Generator::create(const SceneDescription& scene, const TagBitmapSource& tags) {
    Generator generator;
    generator.scene_ = scene;
    generator.renderer_ = SceneRenderer::create(scene, tags);
    return generator;
}

void Generator::renderFrameInto(int index, SynthFrame& out) {
    LIGHTSKIN_ASSERT(index >= 0 && index < frameCount(), "lightskin::synth::Generator::renderFrameInto(): index out of range");
    const Pose world_T_camera = cameraPoseAt(scene_.path, index);
    renderer_.renderInto(world_T_camera, out.exact);

    RgbdFrame& frame = out.frame;
    frame.index = index;
    frame.colourTimestampSeconds = frame.depthTimestampSeconds = double(index) / scene_.path.fps;
    frame.colourIntrinsics = frame.depthIntrinsics = scene_.intrinsics;
    frame.registration = DepthRegistration::RegisteredToColour;
    frame.colour_T_depth = Pose();
    frame.groundTruth_world_T_camera = world_T_camera;
    frame.depthScaleMetres = scene_.depthScaleMetres;

    const cv::Mat& radiance = out.exact.radiance;
    frame.colour.create(radiance.size(), CV_8UC3);
    const auto exposure = float(scene_.exposure);
    for (int v = 0; v < radiance.rows; ++v) {
        const cv::Vec3f* in = radiance.ptr<cv::Vec3f>(v);
        cv::Vec3b* colour = frame.colour.ptr<cv::Vec3b>(v);
        for (int u = 0; u < radiance.cols; ++u)
            for (int c = 0; c < 3; ++c) colour[u][c] = encodeSrgb(exposure * in[u][c]);
    }

    // World normals to the camera frame for the noise model (grazing angles).
    const glm::dmat3 camera_R_world = glm::mat3_cast(glm::conjugate(world_T_camera.rotation()));
    cameraNormals_.create(radiance.size(), CV_32FC3);
    for (int v = 0; v < radiance.rows; ++v) {
        const cv::Vec3f* world = out.exact.worldNormal.ptr<cv::Vec3f>(v);
        cv::Vec3f* camera = cameraNormals_.ptr<cv::Vec3f>(v);
        for (int u = 0; u < radiance.cols; ++u) {
            const glm::dvec3 n = camera_R_world * glm::dvec3(world[u][0], world[u][1], world[u][2]);
            camera[u] = cv::Vec3f(float(n.x), float(n.y), float(n.z));
        }
    }
    applyDepthNoiseInto(out.exact.depthMetres, cameraNormals_, scene_.intrinsics, scene_.noise, index, out.noisyDepthMetres,
                        noiseScratch_);
    depthMetresToUnitsInto(out.noisyDepthMetres, scene_.depthScaleMetres, frame.depth);
}

std::vector<SynthFrame> Generator::renderAll() {
    std::vector<SynthFrame> frames;
    SynthFrame scratch;
    for (int i = 0; i < frameCount(); ++i) {
        renderFrameInto(i, scratch);
        SynthFrame copy;
        copy.frame = scratch.frame.clone();
        copy.exact.radiance = scratch.exact.radiance.clone();
        copy.exact.depthMetres = scratch.exact.depthMetres.clone();
        copy.exact.worldNormal = scratch.exact.worldNormal.clone();
        copy.exact.worldPosition = scratch.exact.worldPosition.clone();
        copy.noisyDepthMetres = scratch.noisyDepthMetres.clone();
        frames.push_back(std::move(copy));
    }
    return frames;
}

} // namespace lightskin::synth
