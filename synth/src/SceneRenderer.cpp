#include "EmbeddedShaders.h"

#include <lightskin/core/Error.h>
#include <lightskin/gl/DebugOutput.h>
#include <lightskin/gl/Readback.h>
#include <lightskin/gl/ShaderLibrary.h>
#include <lightskin/synth/SceneRenderer.h>

#include <glm/gtc/type_ptr.hpp>
#include <opencv2/imgproc.hpp>

#include <array>
#include <cmath>
#include <numeric>
#include <numbers>
#include <vector>

namespace lightskin::synth {

namespace {

constexpr int maxLightSamples = 256; // scene_lights.glsl
constexpr int maxBoxes = 32;

struct Vertex {
    float position[3];
    float normal[3];
    float albedo[3];
    float emission[3];
    float texcoord[2];
};

// std140 mirror of scene_lights.glsl.
struct LightBlock {
    std::int32_t counts[4];
    float ambient[4];
    float samplePosition[maxLightSamples][4];
    float sampleNormal[maxLightSamples][4];
    float sampleIntensity[maxLightSamples][4];
    float boxRows[3 * maxBoxes][4];
    float boxHalfSize[maxBoxes][4];
};

void set3(float* out, const glm::dvec3& v) {
    out[0] = float(v.x);
    out[1] = float(v.y);
    out[2] = float(v.z);
}

// Appends a quad a,b,c,d (in order around it) as two triangles.
void addQuad(std::vector<Vertex>& vertices, const std::array<glm::dvec3, 4>& corners, const glm::dvec3& normal,
             const glm::vec3& albedo, const glm::vec3& emission, const std::array<glm::vec2, 4>& uv = {}) {
    const int order[6] = {0, 1, 2, 0, 2, 3};
    for (int i : order) {
        Vertex vertex{};
        set3(vertex.position, corners[std::size_t(i)]);
        set3(vertex.normal, normal);
        set3(vertex.albedo, glm::dvec3(albedo));
        set3(vertex.emission, glm::dvec3(emission));
        vertex.texcoord[0] = uv[std::size_t(i)].x;
        vertex.texcoord[1] = uv[std::size_t(i)].y;
        vertices.push_back(vertex);
    }
}

// The six faces of a box (centre, half sizes, rotation), normals outward (or inward for the room).
void addBox(std::vector<Vertex>& vertices, const glm::dvec3& center, const glm::dvec3& half, const glm::dmat3& rotation,
            const std::array<glm::vec3, 6>& albedo, bool inward) {
    // Face order: -x, +x, -y, +y, -z, +z.
    for (int axis = 0; axis < 3; ++axis) {
        for (int side = 0; side < 2; ++side) {
            const double sign = side == 0 ? -1.0 : 1.0;
            glm::dvec3 normal(0.0);
            normal[axis] = sign;
            const int a = (axis + 1) % 3, b = (axis + 2) % 3;
            std::array<glm::dvec3, 4> corners;
            const double signsA[4] = {-1, 1, 1, -1}, signsB[4] = {-1, -1, 1, 1};
            for (int i = 0; i < 4; ++i) {
                glm::dvec3 p(0.0);
                p[axis] = sign * half[axis];
                p[a] = signsA[i] * half[a];
                p[b] = signsB[i] * half[b];
                corners[std::size_t(i)] = center + rotation * p;
            }
            addQuad(vertices, corners, rotation * (inward ? -normal : normal), albedo[std::size_t(axis * 2 + side)], glm::vec3(0.0f));
        }
    }
}

glm::dmat3 yawRotation(double yawDegrees) {
    const double angle = yawDegrees * std::numbers::pi / 180.0;
    const double c = std::cos(angle), s = std::sin(angle);
    return glm::dmat3(glm::dvec3(c, s, 0.0), glm::dvec3(-s, c, 0.0), glm::dvec3(0.0, 0.0, 1.0));
}

// n sample offsets in the pixel [-0.5, 0.5)^2 on a rank-1 lattice (x_k = (k + 1/2) / n,
// y_k = frac(a k / n + 1/(2n))): every sample has its own row and column (n-rooks), so a
// near-horizontal or near-vertical edge is resolved in steps of 1/n px, not 1/sqrt(n) as on a
// square grid. `a` maximises the smallest distance between samples on the torus.
std::vector<glm::dvec2> pixelSampleOffsets(int n) {
    int bestA = 1;
    double bestDistance = -1.0;
    for (int a = 1; a < n || a == 1; ++a) {
        if (std::gcd(a, n) != 1) continue;
        double smallest = 1e9;
        for (int k = 1; k < n; ++k) {
            const double dx = std::min(double(k) / n, 1.0 - double(k) / n);
            const double fy = double((a * k) % n) / n;
            const double dy = std::min(fy, 1.0 - fy);
            smallest = std::min(smallest, std::hypot(dx, dy));
        }
        if (smallest > bestDistance + 1e-12) {
            bestDistance = smallest;
            bestA = a;
        }
    }
    std::vector<glm::dvec2> offsets;
    for (int k = 0; k < n; ++k)
        offsets.push_back({(k + 0.5) / n - 0.5, (((bestA * k) % n) + 0.5) / n - 0.5});
    return offsets;
}

struct DrawRange {
    GLint first = 0;
    GLsizei count = 0;
};

} // namespace

glm::dmat4 projectionFromIntrinsics(const CameraIntrinsics& k, double n, double f) {
    const double w = k.width, h = k.height;
    glm::dmat4 m(0.0); // m[column][row]
    m[0][0] = 2.0 * k.fx / w;
    m[2][0] = 2.0 * (k.cx + 0.5) / w - 1.0;
    m[1][1] = -2.0 * k.fy / h;
    m[2][1] = 1.0 - 2.0 * (k.cy + 0.5) / h;
    m[2][2] = (f + n) / (f - n);
    m[3][2] = -2.0 * f * n / (f - n);
    m[2][3] = 1.0;
    return m;
}

std::array<glm::dvec3, 4> SceneRenderer::tagCornersWorld(const TagDescription& tag) {
    const Pose world_T_tag = tag.placement.world_T_face();
    const double h = tag.sizeMetres / 2.0;
    return {world_T_tag.transformPoint({-h, h, 0.0}), world_T_tag.transformPoint({h, h, 0.0}),
            world_T_tag.transformPoint({h, -h, 0.0}), world_T_tag.transformPoint({-h, -h, 0.0})};
}

struct SceneRenderer::Impl {
    SceneDescription scene;
    gl::Program shadedProgram, geometryProgram;
    gl::Buffer vertexBuffer, lightBuffer;
    gl::VertexArray vertexArray;
    DrawRange surfaces, emitters;
    std::vector<DrawRange> tagRanges;
    std::vector<gl::Texture> tagTextures;

    // Colour: one pass per sample offset at the output resolution, averaged on the CPU;
    // geometry: one pass at the pixel centres.
    std::vector<glm::dvec2> sampleOffsets;
    gl::Texture colourTarget;
    gl::Renderbuffer colourDepth;
    gl::Framebuffer colourFramebuffer;
    gl::Texture positionTarget, normalTarget, geometryDummy;
    gl::Renderbuffer geometryDepth;
    gl::Framebuffer geometryFramebuffer;
    cv::Mat readback, readbackNormal, sum;

    void draw(const gl::Program& program, const Pose& world_T_camera, const CameraIntrinsics& intrinsics) {
        program.use();
        const glm::mat4 camera_T_world = world_T_camera.inverse().matrixFloat();
        const glm::mat4 clip_T_camera = glm::mat4(projectionFromIntrinsics(intrinsics, scene.nearMetres, scene.farMetres));
        glUniformMatrix4fv(program.uniformLocation("camera_T_world"), 1, GL_FALSE, glm::value_ptr(camera_T_world));
        glUniformMatrix4fv(program.uniformLocation("clip_T_camera"), 1, GL_FALSE, glm::value_ptr(clip_T_camera));
        const glm::vec3 cameraPosition(world_T_camera.translation());
        glUniform3fv(program.uniformLocation("cameraWorldPosition"), 1, glm::value_ptr(cameraPosition));
        glUniform1f(program.uniformLocation("tagBlackAlbedo"), scene.tagBlackAlbedo);
        glUniform1f(program.uniformLocation("tagWhiteAlbedo"), scene.tagWhiteAlbedo);
        glUniform1i(program.uniformLocation("tagTexture"), 0);
        const GLint useTag = program.uniformLocation("useTagTexture");
        glBindBufferBase(GL_UNIFORM_BUFFER, 0, lightBuffer.id());
        glBindVertexArray(vertexArray.id());
        glEnable(GL_DEPTH_TEST);
        glDepthFunc(GL_LEQUAL);
        glDisable(GL_CULL_FACE);

        glUniform1i(useTag, 0);
        glDrawArrays(GL_TRIANGLES, surfaces.first, surfaces.count);
        // Emitter panels and tags lie on other surfaces: pull them forward in the depth buffer
        // only (the written depth comes from cameraZ, so the geometry stays exact).
        glEnable(GL_POLYGON_OFFSET_FILL);
        glPolygonOffset(-1.0f, -4.0f);
        if (emitters.count > 0) glDrawArrays(GL_TRIANGLES, emitters.first, emitters.count);
        glUniform1i(useTag, 1);
        for (std::size_t i = 0; i < tagRanges.size(); ++i) {
            glBindTextureUnit(0, tagTextures[i].id());
            glDrawArrays(GL_TRIANGLES, tagRanges[i].first, tagRanges[i].count);
        }
        glDisable(GL_POLYGON_OFFSET_FILL);
        glBindVertexArray(0);
    }
};

SceneRenderer::SceneRenderer() = default;
SceneRenderer::~SceneRenderer() = default;
SceneRenderer::SceneRenderer(SceneRenderer&&) noexcept = default;
SceneRenderer& SceneRenderer::operator=(SceneRenderer&&) noexcept = default;

SceneRenderer SceneRenderer::create(const SceneDescription& scene, const TagBitmapSource& tags) {
    scene.validate();
    const std::string source = scene.sourcePath.empty() ? scene.name : scene.sourcePath.string();
    auto impl = std::make_unique<Impl>();
    impl->scene = scene;

    // Geometry.
    std::vector<Vertex> vertices;
    const RoomDescription& room = scene.room;
    addBox(vertices, room.size / 2.0, room.size / 2.0, glm::dmat3(1.0),
           {room.westAlbedo, room.eastAlbedo, room.southAlbedo, room.northAlbedo, room.floorAlbedo, room.ceilingAlbedo}, true);
    for (const BoxDescription& box : scene.boxes) {
        const std::array<glm::vec3, 6> albedo{box.albedo, box.albedo, box.albedo, box.albedo, box.albedo, box.albedo};
        addBox(vertices, box.center, box.size / 2.0, yawRotation(box.yawDegrees), albedo, false);
    }
    impl->surfaces = {0, GLsizei(vertices.size())};

    auto block = std::make_unique<LightBlock>();
    *block = LightBlock{};
    int sampleCount = 0;
    const auto addSample = [&](const glm::dvec3& position, const glm::dvec3& normal, bool isotropic, const glm::dvec3& intensity) {
        if (sampleCount >= maxLightSamples)
            throw Error(source, std::nullopt, "lights: more than " + std::to_string(maxLightSamples) + " light samples in total");
        set3(block->samplePosition[sampleCount], position);
        block->samplePosition[sampleCount][3] = isotropic ? 1.0f : 0.0f;
        set3(block->sampleNormal[sampleCount], normal);
        set3(block->sampleIntensity[sampleCount], intensity);
        ++sampleCount;
    };
    for (const LightDescription& light : scene.lights) {
        const glm::dvec3 power(light.powerWatts);
        if (light.type == LightType::Point) {
            addSample(light.placement.position, glm::dvec3(0.0), true, power / (4.0 * std::numbers::pi));
            continue;
        }
        const Pose world_T_light = light.placement.world_T_face();
        const glm::dvec3 facing = glm::normalize(light.placement.facing);
        const int n = light.samples;
        const double area = light.size.x * light.size.y;
        // Midpoint rule: each cell is a small Lambertian patch of area A / n^2 and radiance
        // L_e = P / (pi A): intensity along its normal L_e * A / n^2 = P / (pi n^2).
        const glm::dvec3 intensity = power / (std::numbers::pi * double(n * n));
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                addSample(world_T_light.transformPoint({((i + 0.5) / n - 0.5) * light.size.x, ((j + 0.5) / n - 0.5) * light.size.y, 0.0}),
                          facing, false, intensity);
        const double hx = light.size.x / 2.0, hy = light.size.y / 2.0;
        const glm::vec3 emission(power / (std::numbers::pi * area));
        addQuad(vertices,
                {world_T_light.transformPoint({-hx, -hy, 0.0}), world_T_light.transformPoint({hx, -hy, 0.0}),
                 world_T_light.transformPoint({hx, hy, 0.0}), world_T_light.transformPoint({-hx, hy, 0.0})},
                facing, glm::vec3(0.0f), emission);
    }
    impl->emitters = {impl->surfaces.count, GLsizei(vertices.size()) - impl->surfaces.count};
    block->counts[0] = sampleCount;
    block->counts[1] = std::int32_t(scene.boxes.size());
    set3(block->ambient, glm::dvec3(scene.ambientRadiance));
    for (std::size_t b = 0; b < scene.boxes.size(); ++b) {
        const BoxDescription& box = scene.boxes[b];
        // box_T_world = R^T (p - c).
        const glm::dmat3 rotationT = glm::transpose(yawRotation(box.yawDegrees));
        const glm::dvec3 translation = -(rotationT * box.center);
        for (int row = 0; row < 3; ++row) {
            float* out = block->boxRows[3 * b + std::size_t(row)];
            for (int column = 0; column < 3; ++column) out[column] = float(rotationT[column][row]);
            out[3] = float(translation[row]);
        }
        set3(block->boxHalfSize[b], box.size / 2.0);
    }

    // Tags: the whole bitmap (quiet zone included) on a quad, black border of edge `size`.
    for (const TagDescription& tag : scene.tags) {
        const TagBitmap bitmap = tags(tag.family, tag.id);
        if (bitmap.cells.type() != CV_8UC1 || bitmap.cells.rows != bitmap.cells.cols || bitmap.borderCells <= 0 ||
            bitmap.borderStartCell < 0 || bitmap.borderStartCell + bitmap.borderCells > bitmap.cells.cols)
            throw Error(source, std::nullopt, "tag " + tag.family + " " + std::to_string(tag.id) + ": bad bitmap");
        const Pose world_T_tag = tag.placement.world_T_face();
        // The bitmap's edges in the tag frame: the border square is [-size/2, size/2]^2.
        const double cell = tag.sizeMetres / double(bitmap.borderCells);
        const double left = -tag.sizeMetres / 2.0 - bitmap.borderStartCell * cell;
        const double right = left + bitmap.cells.cols * cell;
        const double top = tag.sizeMetres / 2.0 + bitmap.borderStartCell * cell;
        const double bottom = top - bitmap.cells.rows * cell;
        const DrawRange range{GLint(vertices.size()), 6};
        // Bitmap row 0 (texture t = 0) at the top edge (+y of the tag frame).
        addQuad(vertices,
                {world_T_tag.transformPoint({left, top, 0.0}), world_T_tag.transformPoint({right, top, 0.0}),
                 world_T_tag.transformPoint({right, bottom, 0.0}), world_T_tag.transformPoint({left, bottom, 0.0})},
                glm::normalize(tag.placement.facing), glm::vec3(1.0f), glm::vec3(0.0f),
                {glm::vec2(0, 0), glm::vec2(1, 0), glm::vec2(1, 1), glm::vec2(0, 1)});
        impl->tagRanges.push_back(range);
        gl::Texture texture = gl::Texture::create2D(GL_R8, bitmap.cells.cols, bitmap.cells.rows);
        const cv::Mat cells = bitmap.cells.isContinuous() ? bitmap.cells : bitmap.cells.clone();
        glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
        glTextureSubImage2D(texture.id(), 0, 0, 0, cells.cols, cells.rows, GL_RED, GL_UNSIGNED_BYTE, cells.data);
        impl->tagTextures.push_back(std::move(texture));
    }

    impl->vertexBuffer = gl::Buffer::create(GLsizeiptr(vertices.size() * sizeof(Vertex)), vertices.data(), 0);
    impl->lightBuffer = gl::Buffer::create(sizeof(LightBlock), block.get(), 0);
    impl->vertexArray = gl::VertexArray::create();
    const GLuint vao = impl->vertexArray.id();
    glVertexArrayVertexBuffer(vao, 0, impl->vertexBuffer.id(), 0, sizeof(Vertex));
    const GLuint offsets[5] = {offsetof(Vertex, position), offsetof(Vertex, normal), offsetof(Vertex, albedo),
                               offsetof(Vertex, emission), offsetof(Vertex, texcoord)};
    for (GLuint attribute = 0; attribute < 5; ++attribute) {
        glEnableVertexArrayAttrib(vao, attribute);
        glVertexArrayAttribFormat(vao, attribute, attribute == 4 ? 2 : 3, GL_FLOAT, GL_FALSE, offsets[attribute]);
        glVertexArrayAttribBinding(vao, attribute, 0);
    }

    const gl::ShaderLibrary library{embeddedShaders()};
    impl->shadedProgram = library.buildProgram({{GL_VERTEX_SHADER, "scene.vert"}, {GL_FRAGMENT_SHADER, "scene.frag"}});
    const std::string geometryOnly[] = {"GEOMETRY_ONLY"};
    impl->geometryProgram =
        library.buildProgram({{GL_VERTEX_SHADER, "scene.vert"}, {GL_FRAGMENT_SHADER, "scene.frag"}}, geometryOnly);

    const CameraIntrinsics& k = scene.intrinsics;
    impl->sampleOffsets = pixelSampleOffsets(scene.supersampling * scene.supersampling);
    impl->colourTarget = gl::Texture::create2D(GL_RGBA32F, k.width, k.height);
    impl->colourDepth = gl::Renderbuffer::create(GL_DEPTH_COMPONENT32F, k.width, k.height);
    impl->colourFramebuffer = gl::Framebuffer::create();
    impl->colourFramebuffer.attach(GL_COLOR_ATTACHMENT0, impl->colourTarget);
    impl->colourFramebuffer.attach(GL_DEPTH_ATTACHMENT, impl->colourDepth);
    impl->colourFramebuffer.checkComplete("synth colour framebuffer");

    impl->geometryDummy = gl::Texture::create2D(GL_RGBA8, k.width, k.height);
    impl->positionTarget = gl::Texture::create2D(GL_RGBA32F, k.width, k.height);
    impl->normalTarget = gl::Texture::create2D(GL_RGBA32F, k.width, k.height);
    impl->geometryDepth = gl::Renderbuffer::create(GL_DEPTH_COMPONENT32F, k.width, k.height);
    impl->geometryFramebuffer = gl::Framebuffer::create();
    impl->geometryFramebuffer.attach(GL_COLOR_ATTACHMENT0, impl->geometryDummy);
    impl->geometryFramebuffer.attach(GL_COLOR_ATTACHMENT1, impl->positionTarget);
    impl->geometryFramebuffer.attach(GL_COLOR_ATTACHMENT2, impl->normalTarget);
    impl->geometryFramebuffer.attach(GL_DEPTH_ATTACHMENT, impl->geometryDepth);
    const GLenum drawBuffers[3] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
    glNamedFramebufferDrawBuffers(impl->geometryFramebuffer.id(), 3, drawBuffers);
    impl->geometryFramebuffer.checkComplete("synth geometry framebuffer");
    gl::DebugOutput::throwIfErrors("synth scene setup");

    SceneRenderer renderer;
    renderer.impl_ = std::move(impl);
    return renderer;
}

void SceneRenderer::renderInto(const Pose& world_T_camera, RenderedView& out) {
    LIGHTSKIN_ASSERT(impl_ != nullptr, "lightskin::synth::SceneRenderer::renderInto(): empty renderer");
    Impl& impl = *impl_;
    const CameraIntrinsics& k = impl.scene.intrinsics;
    const float zero[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    const float one = 1.0f;

    // Radiance: the mean of the samples at sampleOffsets (a box filter over the pixel, in linear
    // space). A sample at offset (dx, dy) from the pixel centre is the pixel centre of a camera
    // whose principal point is shifted by (-dx, -dy).
    glViewport(0, 0, k.width, k.height);
    for (std::size_t i = 0; i < impl.sampleOffsets.size(); ++i) {
        CameraIntrinsics shifted = k;
        shifted.cx -= impl.sampleOffsets[i].x;
        shifted.cy -= impl.sampleOffsets[i].y;
        glBindFramebuffer(GL_FRAMEBUFFER, impl.colourFramebuffer.id());
        glClearNamedFramebufferfv(impl.colourFramebuffer.id(), GL_COLOR, 0, zero);
        glClearNamedFramebufferfv(impl.colourFramebuffer.id(), GL_DEPTH, 0, &one);
        impl.draw(impl.shadedProgram, world_T_camera, shifted);
        gl::readTextureRgba32fInto(impl.colourTarget, impl.readback);
        if (i == 0)
            impl.readback.copyTo(impl.sum);
        else
            impl.sum += impl.readback;
    }
    cv::cvtColor(impl.sum, out.radiance, cv::COLOR_RGBA2BGR);
    out.radiance *= 1.0 / double(impl.sampleOffsets.size());

    glBindFramebuffer(GL_FRAMEBUFFER, impl.geometryFramebuffer.id());
    glViewport(0, 0, k.width, k.height);
    for (GLint i = 0; i < 3; ++i) glClearNamedFramebufferfv(impl.geometryFramebuffer.id(), GL_COLOR, i, zero);
    glClearNamedFramebufferfv(impl.geometryFramebuffer.id(), GL_DEPTH, 0, &one);
    impl.draw(impl.geometryProgram, world_T_camera, k);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);

    gl::readTextureRgba32fInto(impl.positionTarget, impl.readback);
    out.worldPosition.create(k.height, k.width, CV_32FC3);
    out.depthMetres.create(k.height, k.width, CV_32FC1);
    const int fromTo[] = {0, 0, 1, 1, 2, 2, 3, 3};
    cv::Mat outputs[] = {out.worldPosition, out.depthMetres};
    cv::mixChannels(&impl.readback, 1, outputs, 2, fromTo, 4);
    gl::readTextureRgba32fInto(impl.normalTarget, impl.readbackNormal);
    cv::cvtColor(impl.readbackNormal, out.worldNormal, cv::COLOR_RGBA2RGB);
    gl::DebugOutput::throwIfErrors("synth render");
}

} // namespace lightskin::synth
