#include "FramePrefetcher.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/LeakCheck.h>
#include <lightskin/core/Log.h>
#include <lightskin/gl/DebugOutput.h>
#include <lightskin/gl/ShaderLibrary.h>
#include <lightskin/gl/StateGuard.h>
#include <lightskin/mr/Session.h>
#include <lightskin/render/CameraProjection.h>

#include <opencv2/imgproc.hpp>

#include <cmath>

namespace lightskin::mr {

std::span<const gl::EmbeddedFile> embeddedShaders();

namespace {

bool sameCamera(const CameraIntrinsics& a, const CameraIntrinsics& b) {
    return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy;
}

std::string describeCamera(const CameraIntrinsics& k) {
    return std::to_string(k.width) + "x" + std::to_string(k.height) + " fx " + std::to_string(k.fx) + " fy " +
           std::to_string(k.fy) + " cx " + std::to_string(k.cx) + " cy " + std::to_string(k.cy);
}

QualitySettings qualityOf(const render::GiSettings& gi) {
    QualitySettings q;
    q.technique = gi.technique == Technique::BruteForce ? Technique::BruteForce : Technique::LightSkin;
    q.sparsePoints = gi.sparsePoints;
    q.valStride = gi.valStride;
    q.glossy = gi.glossy;
    q.occlusion = gi.occlusion && q.technique == Technique::LightSkin;
    return q;
}

double stageMs(const std::vector<gl::StageTime>& times, std::string_view name) {
    for (const gl::StageTime& t : times)
        if (t.name == name) return t.milliseconds;
    return 0.0;
}

} // namespace

/// The GL objects of render(): created with the session, used on its context.
struct Session::Gl {
    gl::Program program;
    gl::VertexArray vertexArray;
    gl::Framebuffer textureTarget; ///< wraps a host texture for RenderTarget::texture
    gl::Texture composite;         ///< RGBA8 upload of the CPU composite (CompositeOverCamera)
    GLint modeLocation = -1, writeDepthLocation = -1, nearLocation = -1, farLocation = -1;
};

Session::~Session() {
    stopReadAhead();
    // The pipeline's and render()'s GL objects are deleted on the host's context: keep its bindings.
    const gl::StateGuard guard;
    gl_.reset();
    pipeline_.reset();
}

std::unique_ptr<Session> Session::createWith(const SessionOptions& options, const SceneInput& input,
                                             const capture::FrameSourceInfo& info) {
    const gl::StateGuard guard;
    // The host created and made current its own context, so its GL driver is loaded but was never
    // pinned by our context code: in ASan builds keep it mapped, or LeakSanitizer cannot scan the
    // driver's memory at exit after the host's (or Mesa's atexit) eglTerminate unloads it, and
    // reports what only the driver referenced as leaked. A no-op in other builds.
    sanitizer::keepLoadedModulesMapped();
    std::unique_ptr<Session> s(new Session());
    s->options_ = options;
    s->camera_ = info.colourIntrinsics;
    render::Scene scene = input.json.empty() ? render::loadScene(input.file)
                                             : render::parseScene(input.json, input.baseFolder, "in-memory scene");
    if (options.prtCacheDirectory)
        scene.gi.multiscalePrt.cacheDirectory = options.prtCacheDirectory->lexically_normal();
    const double budgetMs = options.budgetMs > 0.0 ? options.budgetMs : scene.gi.budgetMs;
    if (budgetMs > 0.0 && scene.gi.technique == gi::Technique::None) {
        log::warning("frame budget: the scene's technique is \"none\"; no budget applies");
    }
    s->pipeline_ = FramePipeline::create(scene, info, options.pipeline);
    s->applied_ = qualityOf(s->pipeline_->giSettings());
    if (budgetMs > 0.0 && scene.gi.technique != gi::Technique::None) {
        BudgetOptions budget = options.budget;
        budget.budgetMs = budgetMs;
        s->budget_.emplace(budget, sceneNeeds(s->pipeline_->renderer().instances()), s->applied_);
        // Start from the budget's version of the scene's settings (channels the scene cannot use off).
        s->applied_ = s->budget_->current();
        s->pipeline_->setGiSettings(applyTo(s->applied_, s->pipeline_->giSettings()));
    }
    auto g = std::make_unique<Gl>();
    const gl::ShaderLibrary library{embeddedShaders()};
    g->program = library.buildProgram({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "host_draw.frag"}});
    g->vertexArray = gl::VertexArray::create();
    g->textureTarget = gl::Framebuffer::create();
    g->composite = gl::Texture::create2D(GL_RGBA8, s->camera_.width, s->camera_.height);
    g->modeLocation = g->program.uniformLocation("mode");
    g->writeDepthLocation = g->program.uniformLocation("writeDepth");
    g->nearLocation = g->program.uniformLocation("nearMetres");
    g->farLocation = g->program.uniformLocation("farMetres");
    s->gl_ = std::move(g);
    s->frame_.colour.create(s->camera_.height, s->camera_.width, CV_8UC3);
    gl::DebugOutput::throwIfErrors("session creation");
    return s;
}

std::unique_ptr<Session> Session::create(const SessionOptions& options, const SceneInput& scene,
                                         const CameraIntrinsics& camera) {
    if (!camera.isValid()) throw Error("session", std::nullopt, "invalid camera intrinsics " + describeCamera(camera));
    capture::FrameSourceInfo info;
    info.kind = "host";
    info.uri = "host frames";
    info.colourIntrinsics = camera;
    info.depthIntrinsics = camera;
    info.registration = DepthRegistration::RegisteredToColour;
    info.hasGroundTruth = true; // the host's poses
    return createWith(options, scene, info);
}

std::unique_ptr<Session> Session::create(const SessionOptions& options, const SceneInput& scene,
                                         const capture::FrameSourceInfo& info) {
    return createWith(options, scene, info);
}

std::unique_ptr<Session> Session::create(const SessionOptions& options, const SceneInput& scene,
                                         std::unique_ptr<capture::FrameSource> source) {
    LIGHTSKIN_ASSERT(source != nullptr, "lightskin::mr::Session::create(): no source");
    auto s = createWith(options, scene, source->info());
    s->source_ = std::move(source);
    return s;
}

bool Session::processNext() {
    if (!source_)
        throw Error("session", std::nullopt, "processNext() needs a source-fed session (this one takes submit())");
    if (options_.prefetch) {
        if (!prefetch_) {
            prefetch_ = std::make_unique<FramePrefetcher>(*source_, *pipeline_);
            // The next frame's GI while this one reads back and composites (not under a budget, whose
            // cost model times the GI stage of each frame).
            pipeline_->setGiAhead(!budget_.has_value());
            pipeline_->setDifferentialAlongside(!budget_.has_value());
        }
        const FramePrefetcher::Slot* slot = prefetch_->next();
        if (slot == nullptr) return false;
        current_ = &slot->frame;
        processWith(slot->frame, &slot->prepared, prefetch_.get());
        return true;
    }
    if (!source_->next(frame_)) return false;
    current_ = &frame_;
    process(frame_);
    return true;
}

void Session::submit(const HostFrame& host) {
    const std::int64_t index = report_.frameIndex + 1;
    if (host.rgb == nullptr) throw Error("submitted frame", index, "no colour image (rgb is null)");
    if (!sameCamera(host.intrinsics, camera_))
        throw Error("submitted frame", index,
                    "intrinsics " + describeCamera(host.intrinsics) + " differ from the session's camera " +
                        describeCamera(camera_));
    if (host.depth != nullptr && !(host.depthScaleMetres > 0.0 && std::isfinite(host.depthScaleMetres)))
        throw Error("submitted frame", index,
                    "depthScaleMetres must be a positive number, got " + std::to_string(host.depthScaleMetres));
    const int w = camera_.width, h = camera_.height;
    const std::size_t rgbStep = host.rgbRowBytes != 0 ? host.rgbRowBytes : std::size_t(w) * 3;
    const std::size_t depthStep = host.depthRowBytes != 0 ? host.depthRowBytes : std::size_t(w) * 2;
    if (rgbStep < std::size_t(w) * 3 || (host.depth != nullptr && depthStep < std::size_t(w) * 2))
        throw Error("submitted frame", index, "row stride smaller than a row");
    // Headers over the host's memory (read only: cvtColor reads, the pipeline reads depth).
    const cv::Mat rgb(h, w, CV_8UC3, const_cast<std::uint8_t*>(host.rgb), rgbStep);
    cv::cvtColor(rgb, frame_.colour, cv::COLOR_RGB2BGR); // into the session's buffer (allocated once)
    frame_.depth =
        host.depth != nullptr ? cv::Mat(h, w, CV_16UC1, const_cast<std::uint16_t*>(host.depth), depthStep) : cv::Mat();
    frame_.index = index;
    frame_.depthScaleMetres = host.depthScaleMetres;
    frame_.colourTimestampSeconds = frame_.depthTimestampSeconds = host.timestampSeconds;
    frame_.colourIntrinsics = frame_.depthIntrinsics = camera_;
    frame_.registration = DepthRegistration::RegisteredToColour;
    frame_.colour_T_depth = Pose();
    frame_.groundTruth_world_T_camera = host.world_T_camera;
    current_ = &frame_;
    process(frame_);
    frame_.depth = cv::Mat(); // drop the header over host memory
}

void Session::process(const RgbdFrame& frame) {
    LIGHTSKIN_ASSERT(!prefetch_,
                     "lightskin::mr::Session::process(): the session prefetches its source (processNext() only)");
    processWith(frame, nullptr, nullptr);
}

void Session::processWith(const RgbdFrame& frame, const PreparedFrame* prepared, NextFrame* nextFrame) {
    if (!sameCamera(frame.colourIntrinsics, camera_))
        throw Error("frame", frame.index,
                    "colour intrinsics " + describeCamera(frame.colourIntrinsics) +
                        " differ from the session's camera " + describeCamera(camera_));
    const gl::StateGuard guard;
    double predictedMs = 0.0;
    if (budget_ && lastStats_) {
        const QualitySettings next = budget_->choose(*lastStats_);
        predictedMs = budget_->predictMs(next, *lastStats_);
        if (!(next == applied_)) {
            log::info("frame budget " + std::to_string(budget_->budgetMs()) + " ms: frame " +
                      std::to_string(frame.index) + " switches to " + describe(next));
            pipeline_->setGiSettings(applyTo(next, pipeline_->giSettings()));
            applied_ = next;
        }
    }
    if (prepared != nullptr)
        pipeline_->render(frame, *prepared, output_, nextFrame);
    else
        pipeline_->process(frame, output_);
    if (output_.world_T_camera) {
        const FrameStats stats{double(output_.valCount), applied_.valStride, double(output_.coveredPixels)};
        lastStats_ = stats;
    }
    if (budget_ && output_.world_T_camera) {
        const FrameStats& stats = *lastStats_;
        StageCosts costs;
        if (options_.costMeter) {
            costs = options_.costMeter(applied_, stats, output_);
        } else {
            costs.giMs = stageMs(output_.cpuTimes, "gbuffer+gi");
            costs.otherMs = std::max(0.0, output_.totalMs - costs.giMs);
        }
        budget_->observe(applied_, stats, costs);
    }
    report_.frameIndex = frame.index;
    report_.timestampSeconds = frame.colourTimestampSeconds;
    report_.trackingState = output_.tracking.state;
    report_.world_T_camera = output_.world_T_camera;
    report_.valCount = output_.valCount;
    report_.coveredPixels = output_.coveredPixels;
    report_.totalMs = output_.totalMs;
    report_.settings = applied_;
    report_.technique = pipeline_->technique();
    report_.backend = pipeline_->backend();
    report_.budgetActive = budget_.has_value();
    report_.budgetMs = budget_ ? budget_->budgetMs() : 0.0;
    report_.predictedMs = predictedMs;
    report_.expectedError = budget_ ? budget_->expectedError(applied_) : 0.0;
}

void Session::render(const RenderTarget& target) {
    if (target.content == RenderContent::VirtualOnly && pipeline_->options().compare)
        throw Error("render target", std::nullopt,
                    "VirtualOnly needs the pipeline's compare off (its last shade is the no-GI image)");
    if (!(target.nearMetres > 0.0 && target.farMetres > target.nearMetres))
        throw Error("render target", std::nullopt, "needs 0 < nearMetres < farMetres");
    if (target.width < 0 || target.height < 0) throw Error("render target", std::nullopt, "negative viewport size");
    const gl::StateGuard guard;
    Gl& g = *gl_;
    GLuint framebuffer = target.framebuffer;
    if (target.texture != 0) {
        if (!glIsTexture(target.texture))
            throw Error("render target", std::nullopt,
                        "texture " + std::to_string(target.texture) + " is not a texture");
        glNamedFramebufferTexture(g.textureTarget.id(), GL_COLOR_ATTACHMENT0, target.texture, 0);
        g.textureTarget.checkComplete("render target texture " + std::to_string(target.texture));
        framebuffer = g.textureTarget.id();
    } else if (framebuffer != 0 &&
               glCheckNamedFramebufferStatus(framebuffer, GL_DRAW_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
        throw Error("render target", std::nullopt, "framebuffer " + std::to_string(framebuffer) + " is not complete");
    }
    const bool depth = target.depthTest && target.content == RenderContent::VirtualOnly && target.texture == 0;
    GLuint image = pipeline_->renderer().outputColourTexture();
    if (target.content == RenderContent::CompositeOverCamera) {
        const cv::Mat& composite = output_.withGi;
        if (composite.empty()) throw Error("render target", std::nullopt, "no frame has been processed yet");
        glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
        glPixelStorei(GL_UNPACK_ROW_LENGTH, int(composite.step / 3));
        glTextureSubImage2D(g.composite.id(), 0, 0, 0, composite.cols, composite.rows, GL_BGR, GL_UNSIGNED_BYTE,
                            composite.data);
        image = g.composite.id();
    }
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, framebuffer);
    glViewport(target.x, target.y, target.width > 0 ? target.width : camera_.width,
               target.height > 0 ? target.height : camera_.height);
    glDisable(GL_BLEND);
    glDisable(GL_CULL_FACE);
    glDisable(GL_SCISSOR_TEST);
    glDisable(GL_STENCIL_TEST);
    glDisable(GL_RASTERIZER_DISCARD);
    glDisable(GL_FRAMEBUFFER_SRGB); // the images are sRGB-encoded already
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    if (depth) {
        glEnable(GL_DEPTH_TEST);
        glDepthFunc(GL_LESS);
        glDepthMask(GL_TRUE);
    } else {
        glDisable(GL_DEPTH_TEST);
    }
    glProgramUniform1i(g.program.id(), g.modeLocation, target.content == RenderContent::CompositeOverCamera ? 1 : 0);
    glProgramUniform1i(g.program.id(), g.writeDepthLocation, depth ? 1 : 0);
    glProgramUniform1f(g.program.id(), g.nearLocation, float(target.nearMetres));
    glProgramUniform1f(g.program.id(), g.farLocation, float(target.farMetres));
    glBindTextureUnit(0, image);
    glBindTextureUnit(1, pipeline_->renderer().outputDepthTexture());
    glBindSampler(0, 0);
    glBindSampler(1, 0);
    g.program.use();
    glBindVertexArray(g.vertexArray.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    if (target.texture != 0) glNamedFramebufferTexture(g.textureTarget.id(), GL_COLOR_ATTACHMENT0, 0, 0);
}

void Session::setObjectTransform(std::size_t object, const glm::mat4& world_T_model) {
    pipeline_->setObjectTransform(object, world_T_model);
}
void Session::setObjectVisible(std::size_t object, bool visible) { pipeline_->setObjectVisible(object, visible); }
void Session::setObjectMaterial(std::size_t object, const render::MaterialOverride& material) {
    pipeline_->setObjectMaterial(object, material);
}
void Session::setLight(std::size_t light, const glm::vec3& position, const glm::vec3& direction,
                       const glm::vec3& power) {
    pipeline_->setLight(light, position, direction, power);
}
std::size_t Session::addObject(render::SceneObject object) { return pipeline_->addObject(std::move(object)); }
void Session::removeObject(std::size_t object) { pipeline_->removeObject(object); }

void Session::setBudgetMs(double budgetMs) {
    pipeline_->setGiAhead(false); // see processNext()
    pipeline_->setDifferentialAlongside(false);
    if (budget_) {
        budget_->setBudgetMs(budgetMs);
        return;
    }
    if (pipeline_->giSettings().technique == gi::Technique::None)
        throw Error("frame budget", std::nullopt, "the scene's technique is \"none\": nothing to budget");
    BudgetOptions budget = options_.budget;
    budget.budgetMs = budgetMs;
    budget_.emplace(budget, sceneNeeds(pipeline_->renderer().instances()), applied_);
}

glm::mat4 Session::projection(double nearMetres, double farMetres) const {
    return glm::mat4(render::clipFromCamera(camera_, nearMetres, farMetres));
}

glm::mat4 Session::viewMatrix() const {
    if (!report_.world_T_camera) return glm::mat4(1.0f);
    return glm::mat4(report_.world_T_camera->inverse().matrix());
}

void Session::stopReadAhead() {
    if (pipeline_) pipeline_->finishGiAhead();
    prefetch_.reset();
}

void Session::saveRoomModel(const std::filesystem::path& file) {
    stopReadAhead();
    pipeline_->saveRoomModel(file);
}

void Session::loadRoomModel(const std::filesystem::path& file) {
    stopReadAhead();
    pipeline_->loadRoomModel(file);
}

} // namespace lightskin::mr
