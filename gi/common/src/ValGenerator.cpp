#include "LightsShaders.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/common/ValGenerator.h>
#include <lightskin/gl/ShaderLibrary.h>

#include <glm/gtc/type_ptr.hpp>
#include <opencv2/core.hpp>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

namespace lightskin::gi {

void validate(const ValGeneratorSettings& s) {
    const auto fail = [](const char* field, const std::string& why) {
        throw Error(std::string("ValGeneratorSettings.") + field, std::nullopt, why);
    };
    if (s.stride < 1 || s.stride > 64) fail("stride", "must be in [1, 64], got " + std::to_string(s.stride));
    if (!(s.exposure >= 0.0f) || !std::isfinite(s.exposure)) fail("exposure", "must be finite and >= 0");
    if (s.normalWindowRadius < 1 || s.normalWindowRadius > 32)
        fail("normalWindowRadius", "must be in [1, 32], got " + std::to_string(s.normalWindowRadius));
    if (!(s.maxDepthChange > 0.0f) || !std::isfinite(s.maxDepthChange)) fail("maxDepthChange", "must be finite and > 0");
    if (!(s.minCosine > 0.0f && s.minCosine <= 1.0f)) fail("minCosine", "must be in (0, 1]");
    if (!(s.minDepth >= 0.0f) || !(s.maxDepth > s.minDepth) || !std::isfinite(s.maxDepth))
        fail("minDepth/maxDepth", "need 0 <= minDepth < maxDepth < inf");
    if (!(s.pclMaxDepthChangeFactor > 0.0f)) fail("pclMaxDepthChangeFactor", "must be > 0");
}

double srgbToLinear(double encoded) noexcept {
    return encoded <= 0.04045 ? encoded / 12.92 : std::pow((encoded + 0.055) / 1.055, 2.4);
}

ValGenerator ValGenerator::create(int depthWidth, int depthHeight, const ValGeneratorSettings& settings) {
    validate(settings);
    if (depthWidth < 1 || depthHeight < 1 || depthWidth > 16384 || depthHeight > 16384)
        throw Error("ValGenerator", std::nullopt,
                    "depth map size " + std::to_string(depthWidth) + "x" + std::to_string(depthHeight) + " out of range");
    ValGenerator g;
    g.settings_ = settings;
    g.width_ = depthWidth;
    g.height_ = depthHeight;
    const int mapW = valMapWidth(depthWidth, settings), mapH = valMapHeight(depthHeight, settings);
    g.capacity_ = std::uint32_t(std::max(1, mapW * mapH));
    const gl::ShaderLibrary library{embeddedShaders()};
    // Shared-memory tile of the work group's depth footprint when it fits in 16 KB (else texel fetches).
    const int tileSize = 7 * settings.stride + 2 * settings.normalWindowRadius + 1;
    std::vector<std::string> defines;
    if (tileSize <= 64) defines.push_back("TILE_SIZE " + std::to_string(tileSize));
    g.program_ = library.buildProgram({{GL_COMPUTE_SHADER, "val_from_depth.comp"}}, defines);
    g.depthTexture_ = gl::Texture::create2D(GL_R32F, depthWidth, depthHeight);
    g.colourTexture_ = gl::Texture::create2D(GL_RGBA8, depthWidth, depthHeight);
    g.vals_ = gl::Buffer::create(GLsizeiptr(g.capacity_) * GLsizeiptr(sizeof(VirtualAreaLight)));
    g.pixelIndices_ = gl::Buffer::create(GLsizeiptr(g.capacity_) * GLsizeiptr(sizeof(std::uint32_t)));
    g.counter_ = gl::Buffer::create(sizeof(std::uint32_t));
    g.depthMetres_.create(depthHeight, depthWidth, CV_32FC1);
    if (settings.skipUnchangedInput) g.reservePreviousInput();
    return g;
}

void ValGenerator::setSettings(const ValGeneratorSettings& settings) {
    validate(settings);
    LIGHTSKIN_ASSERT(settings.stride == settings_.stride && settings.normalWindowRadius == settings_.normalWindowRadius,
                     "the stride and the normal window are fixed at create()");
    settings_ = settings;
    previousValid_ = false; // the next generate() runs the pass
    if (settings.skipUnchangedInput) reservePreviousInput();
}

void ValGenerator::reservePreviousInput() {
    previousDepth_.create(height_, width_, CV_32FC1);
    previousColour_.create(height_, width_, CV_8UC3);
}

namespace {

/// Bit-exact comparison of two images of equal size and type (NaN equals NaN of the same bits).
bool sameBits(const cv::Mat& a, const cv::Mat& b) {
    const std::size_t rowBytes = std::size_t(a.cols) * a.elemSize();
    for (int y = 0; y < a.rows; ++y)
        if (std::memcmp(a.ptr(y), b.ptr(y), rowBytes) != 0) return false;
    return true;
}

} // namespace

ValSetView ValGenerator::generate(const RgbdFrame& frame, const Pose& world_T_camera) {
    if (frame.registration != DepthRegistration::RegisteredToColour)
        throw Error("ValGenerator", frame.index, "depth must be registered to colour");
    return generate(frame.depth, frame.depthScaleMetres, frame.colour, frame.depthIntrinsics, world_T_camera);
}

ValSetView ValGenerator::generate(const cv::Mat& depth, double depthScaleMetres, const cv::Mat& colourBgr,
                                  const CameraIntrinsics& K, const Pose& world_T_camera) {
    LIGHTSKIN_ASSERT(program_, "ValGenerator used before create()");
    if (depth.cols != width_ || depth.rows != height_ || (depth.type() != CV_16UC1 && depth.type() != CV_32FC1))
        throw Error("ValGenerator", std::nullopt,
                    "depth must be CV_16UC1 or CV_32FC1 of " + std::to_string(width_) + "x" + std::to_string(height_));
    if (colourBgr.size() != depth.size() || colourBgr.type() != CV_8UC3)
        throw Error("ValGenerator", std::nullopt, "colour must be CV_8UC3 (BGR) of the depth map's size");
    if (!(K.fx != 0.0 && K.fy != 0.0 && std::isfinite(K.fx) && std::isfinite(K.fy) && std::isfinite(K.cx) &&
          std::isfinite(K.cy)))
        throw Error("ValGenerator", std::nullopt, "invalid intrinsics: " + K.describe());

    const cv::Mat* depthMetres = &depth;
    if (depth.type() == CV_16UC1) {
        depth.convertTo(depthMetres_, CV_32FC1, depthScaleMetres); // sized at create(): no allocation
        depthMetres = &depthMetres_;
    }
    lastSkipped_ = false;
    if (settings_.skipUnchangedInput) {
        const glm::dvec4 intrinsics(K.fx, K.fy, K.cx, K.cy);
        if (previousValid_ && intrinsics == previousIntrinsics_ && world_T_camera.rotation() == previousPose_.rotation() &&
            world_T_camera.translation() == previousPose_.translation() && sameBits(*depthMetres, previousDepth_) &&
            sameBits(colourBgr, previousColour_)) {
            lastSkipped_ = true;
            if (timer_) // the same stages every frame, empty
                for (const char* stage : {"val upload", "val pass"}) {
                    timer_->begin(stage);
                    timer_->end();
                }
            return lastSet();
        }
        depthMetres->copyTo(previousDepth_); // same size and type: no allocation
        colourBgr.copyTo(previousColour_);
        previousIntrinsics_ = intrinsics;
        previousPose_ = world_T_camera;
        previousValid_ = true;
    }
    ++generation_;
    if (timer_) timer_->begin("val upload");
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, int(depthMetres->step1()));
    glTextureSubImage2D(depthTexture_.id(), 0, 0, 0, width_, height_, GL_RED, GL_FLOAT, depthMetres->data);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, int(colourBgr.step / 3));
    glTextureSubImage2D(colourTexture_.id(), 0, 0, 0, width_, height_, GL_BGR, GL_UNSIGNED_BYTE, colourBgr.data);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);

    if (timer_) {
        timer_->end();
        timer_->begin("val pass");
    }
    const std::uint32_t zero = 0;
    glClearNamedBufferData(counter_.id(), GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, &zero);
    const int mapW = valMapWidth(width_, settings_), mapH = valMapHeight(height_, settings_);
    const GLuint p = program_.id();
    program_.use();
    glUniform2i(program_.uniformLocation("depthSize"), width_, height_);
    glUniform2i(program_.uniformLocation("valMapSize"), mapW, mapH);
    glUniform1i(program_.uniformLocation("stride"), settings_.stride);
    glUniform1i(program_.uniformLocation("windowRadius"), settings_.normalWindowRadius);
    glUniform4f(program_.uniformLocation("intrinsics"), float(K.fx), float(K.fy), float(K.cx), float(K.cy));
    const glm::mat4 pose = world_T_camera.matrixFloat();
    glProgramUniformMatrix4fv(p, program_.uniformLocation("world_T_camera"), 1, GL_FALSE, glm::value_ptr(pose));
    glUniform1f(program_.uniformLocation("exposure"), settings_.exposure);
    glUniform1f(program_.uniformLocation("maxDepthChange"), settings_.maxDepthChange);
    glUniform1f(program_.uniformLocation("minCosine"), settings_.minCosine);
    glUniform1f(program_.uniformLocation("minDepth"), settings_.minDepth);
    glUniform1f(program_.uniformLocation("maxDepth"), settings_.maxDepth);
    glUniform1ui(program_.uniformLocation("capacity"), capacity_);
    glBindTextureUnit(0, depthTexture_.id());
    glBindTextureUnit(1, colourTexture_.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, vals_.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, pixelIndices_.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, counter_.id());
    glDispatchCompute(GLuint((mapW + 7) / 8), GLuint((mapH + 7) / 8), 1);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT | GL_UNIFORM_BARRIER_BIT);
    if (timer_) timer_->end();
    std::uint32_t count = 0;
    glGetNamedBufferSubData(counter_.id(), 0, sizeof count, &count);
    lastCount_ = std::min(count, capacity_);
    return lastSet();
}

std::vector<VirtualAreaLight> ValGenerator::downloadVals() const {
    std::vector<VirtualAreaLight> out(lastCount_);
    if (lastCount_ > 0)
        glGetNamedBufferSubData(vals_.id(), 0, GLsizeiptr(out.size() * sizeof(VirtualAreaLight)), out.data());
    return out;
}

std::vector<std::uint32_t> ValGenerator::downloadPixelIndices() const {
    std::vector<std::uint32_t> out(lastCount_);
    if (lastCount_ > 0)
        glGetNamedBufferSubData(pixelIndices_.id(), 0, GLsizeiptr(out.size() * sizeof(std::uint32_t)), out.data());
    return out;
}

} // namespace lightskin::gi
