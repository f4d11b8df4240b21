// The C ABI over mr::Session. Every entry point catches everything: no exception crosses into C.
// Versioned structs: inputs are copied into a default-initialised struct up to the caller's
// struct_size; outputs are filled completely here and copied out up to the caller's struct_size.
#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>
#include <lightskin/mr/Session.h>

#include <glm/gtc/type_ptr.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstring>
#include <exception>
#include <filesystem>
#include <lightskin.h>
#include <new>
#include <string>
#include <type_traits>

struct lsk_session {
    std::unique_ptr<lightskin::mr::Session> session;
};

namespace {

namespace mr = lightskin::mr;
namespace gi = lightskin::gi;

int32_t techniqueOf(gi::Technique technique) {
    switch (technique) {
    case gi::Technique::LightSkin:
        return LSK_TECHNIQUE_LIGHTSKIN;
    case gi::Technique::BruteForce:
        return LSK_TECHNIQUE_BRUTE_FORCE;
    case gi::Technique::ImperfectVolumes:
        return LSK_TECHNIQUE_IMPERFECT_VOLUMES;
    case gi::Technique::MultiscalePrt:
        return LSK_TECHNIQUE_MULTISCALE_PRT;
    case gi::Technique::None:
        return LSK_TECHNIQUE_NONE;
    }
    return LSK_TECHNIQUE_NONE;
}

thread_local std::string lastError;

lsk_status fail(lsk_status status, std::string message) {
    lastError = std::move(message);
    return status;
}

/// Runs `body` with every exception turned into a status and lsk_last_error() text.
template <typename Body>
lsk_status guarded(const char* function, Body&& body) noexcept {
    try {
        lastError.clear();
        return body();
    } catch (const lightskin::Error& error) {
        return fail(LSK_ERROR_INPUT, std::string(function) + ": " + error.what());
    } catch (const std::bad_alloc&) {
        return fail(LSK_ERROR_OUT_OF_MEMORY, std::string(function) + ": out of memory");
    } catch (const std::exception& error) {
        return fail(LSK_ERROR_INTERNAL, std::string(function) + ": " + error.what());
    } catch (...) {
        return fail(LSK_ERROR_INTERNAL, std::string(function) + ": unknown exception");
    }
}

/// guarded() for the entry points on a session: a null handle is LSK_ERROR_INVALID_ARGUMENT naming the
/// function; `body` gets the mr::Session (const for the read-only entry points).
template <typename Handle, typename Body>
lsk_status guardedSession(const char* function, Handle* handle, Body&& body) noexcept {
    return guarded(function, [&]() -> lsk_status {
        if (handle == nullptr) return fail(LSK_ERROR_INVALID_ARGUMENT, std::string(function) + ": session is null");
        return body(*handle->session);
    });
}

lsk_status invalidArgument(const char* function, const std::string& what) {
    return fail(LSK_ERROR_INVALID_ARGUMENT, std::string(function) + ": " + what);
}

/// Copies the caller's struct into `out` (already default-initialised) up to its struct_size.
/// False when the pointer is null or the size does not even cover struct_size.
template <typename T>
bool readVersioned(const T* in, T& out) {
    if (in == nullptr || in->struct_size < sizeof(std::uint32_t)) return false;
    std::memcpy(&out, in, std::min<std::size_t>(in->struct_size, sizeof(T)));
    out.struct_size = std::uint32_t(sizeof(T));
    return true;
}

template <typename T>
void writeVersioned(const T& full, T* out) {
    const std::uint32_t size = out->struct_size;
    std::memcpy(out, &full, std::min<std::size_t>(size, sizeof(T)));
    out->struct_size = size;
}

lightskin::CameraIntrinsics intrinsicsOf(const lsk_camera& c) {
    lightskin::CameraIntrinsics k;
    k.width = c.width;
    k.height = c.height;
    k.fx = c.fx;
    k.fy = c.fy;
    k.cx = c.cx;
    k.cy = c.cy;
    return k;
}

lsk_status sessionOptions(const lsk_session_options* in, mr::SessionOptions& out) {
    lsk_session_options o;
    lsk_session_options_init(&o);
    if (in != nullptr && !readVersioned(in, o))
        return fail(LSK_ERROR_INVALID_ARGUMENT, "lsk_session_options: struct_size not set");
    switch (o.pose_mode) {
    case LSK_POSE_HOST:
        out.pipeline.poseMode = mr::PoseMode::GroundTruth;
        break;
    case LSK_POSE_TRACKING:
        out.pipeline.poseMode = mr::PoseMode::Tracking;
        break;
    case LSK_POSE_FIXED:
        out.pipeline.poseMode = mr::PoseMode::Fixed;
        break;
    default:
        return fail(LSK_ERROR_INVALID_ARGUMENT,
                    "lsk_session_options.pose_mode: " + std::to_string(o.pose_mode) + " is not an lsk_pose_mode");
    }
    out.pipeline.giEnabled = o.gi_enabled != 0;
    if (!(o.budget_ms >= 0.0))
        return fail(LSK_ERROR_INVALID_ARGUMENT, "lsk_session_options.budget_ms: must be >= 0 (0 = the scene's)");
    out.budgetMs = o.budget_ms;
    return LSK_OK;
}

lsk_status sceneInput(const lsk_scene* in, mr::SceneInput& out) {
    lsk_scene s;
    lsk_scene_init(&s);
    if (!readVersioned(in, s)) return fail(LSK_ERROR_INVALID_ARGUMENT, "lsk_scene: null or struct_size not set");
    if (s.json != nullptr)
        out = mr::SceneInput::fromJson(s.json, s.base_folder != nullptr ? s.base_folder : ".");
    else if (s.path != nullptr)
        out = mr::SceneInput::fromFile(s.path);
    else
        return fail(LSK_ERROR_INVALID_ARGUMENT, "lsk_scene: neither path nor json is set");
    return LSK_OK;
}

/// The two lsk_session_create* entry points: `input` (the camera or the source URI) and `out` must be set;
/// `make` builds the session from the parsed options and scene.
template <typename Input, typename Make>
lsk_status createSession(const char* function, const lsk_session_options* options, const lsk_scene* scene,
                         const Input* input, lsk_session** out, Make&& make) noexcept {
    return guarded(function, [&]() -> lsk_status {
        if (out == nullptr || input == nullptr)
            return invalidArgument(function, std::is_same_v<Input, lsk_camera> ? "camera and out must not be null"
                                                                               : "source_uri and out must not be null");
        *out = nullptr;
        mr::SessionOptions o;
        mr::SceneInput s;
        if (lsk_status status = sessionOptions(options, o); status != LSK_OK) return status;
        if (lsk_status status = sceneInput(scene, s); status != LSK_OK) return status;
        auto handle = std::make_unique<lsk_session>();
        handle->session = make(o, s);
        *out = handle.release();
        return LSK_OK;
    });
}

} // namespace

extern "C" {

#define LSK_STRINGIFY_(x) #x
#define LSK_STRINGIFY(x) LSK_STRINGIFY_(x)
const char* lsk_version(void) {
    return LSK_STRINGIFY(LSK_VERSION_MAJOR) "." LSK_STRINGIFY(LSK_VERSION_MINOR) "." LSK_STRINGIFY(LSK_VERSION_PATCH);
}

const char* lsk_last_error(void) { return lastError.c_str(); }

void lsk_session_options_init(lsk_session_options* o) {
    if (o == nullptr) return;
    *o = lsk_session_options{};
    o->struct_size = sizeof(lsk_session_options);
    o->pose_mode = LSK_POSE_HOST;
    o->gi_enabled = 1;
    o->budget_ms = 0.0;
}

void lsk_scene_init(lsk_scene* s) {
    if (s == nullptr) return;
    *s = lsk_scene{};
    s->struct_size = sizeof(lsk_scene);
}

void lsk_frame_init(lsk_frame* f) {
    if (f == nullptr) return;
    *f = lsk_frame{};
    f->struct_size = sizeof(lsk_frame);
    f->depth_scale_metres = 0.001;
    f->timestamp_seconds = std::numeric_limits<double>::quiet_NaN();
    for (int i = 0; i < 4; ++i) f->world_T_camera[5 * i] = 1.0;
}

void lsk_frame_report_init(lsk_frame_report* r) {
    if (r == nullptr) return;
    *r = lsk_frame_report{};
    r->struct_size = sizeof(lsk_frame_report);
    r->frame_index = -1;
}

void lsk_render_target_init(lsk_render_target* t) {
    if (t == nullptr) return;
    *t = lsk_render_target{};
    t->struct_size = sizeof(lsk_render_target);
    t->content = LSK_CONTENT_VIRTUAL_ONLY;
    t->near_metres = 0.05;
    t->far_metres = 20.0;
}

lsk_status lsk_session_create(const lsk_session_options* options, const lsk_scene* scene, const lsk_camera* camera,
                              lsk_session** out) {
    return createSession("lsk_session_create", options, scene, camera, out,
                         [&](const mr::SessionOptions& o, const mr::SceneInput& s) {
                             return mr::Session::create(o, s, intrinsicsOf(*camera));
                         });
}

lsk_status lsk_session_create_from_source(const lsk_session_options* options, const lsk_scene* scene,
                                          const char* sourceUri, lsk_session** out) {
    return createSession("lsk_session_create_from_source", options, scene, sourceUri, out,
                         [&](const mr::SessionOptions& o, const mr::SceneInput& s) {
                             return mr::Session::create(o, s, lightskin::capture::openFrameSource(sourceUri, {}));
                         });
}

void lsk_session_destroy(lsk_session* session) {
    (void)guarded("lsk_session_destroy", [&]() -> lsk_status {
        delete session;
        return LSK_OK;
    });
}

lsk_status lsk_session_process_next(lsk_session* session) {
    return guardedSession("lsk_session_process_next", session,
                          [&](mr::Session& s) -> lsk_status { return s.processNext() ? LSK_OK : LSK_END_OF_STREAM; });
}

lsk_status lsk_session_submit(lsk_session* session, const lsk_frame* frame) {
    constexpr const char* function = "lsk_session_submit";
    return guardedSession(function, session, [&](mr::Session& s) -> lsk_status {
        lsk_frame f;
        lsk_frame_init(&f);
        if (!readVersioned(frame, f)) return invalidArgument(function, "frame is null or frame->struct_size not set");
        mr::HostFrame h;
        h.rgb = f.rgb;
        h.rgbRowBytes = f.rgb_row_bytes;
        h.depth = f.depth;
        h.depthRowBytes = f.depth_row_bytes;
        h.depthScaleMetres = f.depth_scale_metres;
        h.intrinsics = intrinsicsOf(f.camera);
        h.timestampSeconds = f.timestamp_seconds;
        if (f.has_pose) h.world_T_camera = lightskin::Pose::fromMatrix(glm::make_mat4(f.world_T_camera));
        s.submit(h);
        return LSK_OK;
    });
}

lsk_status lsk_session_report(const lsk_session* session, lsk_frame_report* report) {
    constexpr const char* function = "lsk_session_report";
    return guardedSession(function, session, [&](const mr::Session& s) -> lsk_status {
        if (report == nullptr || report->struct_size < sizeof(std::uint32_t))
            return invalidArgument(function, "report is null or report->struct_size not set");
        const mr::FrameReport& r = s.report();
        const mr::FrameOutput& o = s.output();
        lsk_frame_report full;
        lsk_frame_report_init(&full);
        full.frame_index = r.frameIndex;
        full.timestamp_seconds = r.timestampSeconds;
        // lsk_tracking_state mirrors tracking::TrackingState value for value.
        static_assert(int(lightskin::tracking::TrackingState::Tracking) == LSK_TRACKING &&
                      int(lightskin::tracking::TrackingState::Held) == LSK_TRACKING_HELD &&
                      int(lightskin::tracking::TrackingState::Lost) == LSK_TRACKING_LOST &&
                      int(lightskin::tracking::TrackingState::DepthTracked) == LSK_TRACKING_DEPTH);
        full.tracking_state = int32_t(r.trackingState);
        full.has_pose = r.world_T_camera ? 1 : 0;
        if (r.world_T_camera) {
            const glm::dmat4 m = r.world_T_camera->matrix();
            std::memcpy(full.world_T_camera, glm::value_ptr(m), sizeof full.world_T_camera);
        }
        full.val_count = r.valCount;
        full.covered_pixels = r.coveredPixels;
        full.total_ms = r.totalMs;
        full.stage_count = std::uint32_t(std::min<std::size_t>(o.cpuTimes.size(), LSK_MAX_STAGES));
        for (std::uint32_t i = 0; i < full.stage_count; ++i) {
            std::strncpy(full.stages[i].name, o.cpuTimes[i].name.c_str(), sizeof full.stages[i].name - 1);
            full.stages[i].cpu_ms = o.cpuTimes[i].milliseconds;
        }
        full.technique =
            r.settings.technique == gi::Technique::BruteForce ? LSK_TECHNIQUE_BRUTE_FORCE : LSK_TECHNIQUE_LIGHTSKIN;
        full.sparse_points = r.settings.sparsePoints;
        full.val_stride = r.settings.valStride;
        full.glossy = r.settings.glossy ? 1 : 0;
        full.occlusion = r.settings.occlusion ? 1 : 0;
        full.budget_active = r.budgetActive ? 1 : 0;
        full.budget_ms = r.budgetMs;
        full.predicted_ms = r.predictedMs;
        full.expected_error = r.expectedError;
        writeVersioned(full, report);
        return LSK_OK;
    });
}

lsk_status lsk_session_render(lsk_session* session, const lsk_render_target* target) {
    constexpr const char* function = "lsk_session_render";
    return guardedSession(function, session, [&](mr::Session& s) -> lsk_status {
        lsk_render_target t;
        lsk_render_target_init(&t);
        if (!readVersioned(target, t))
            return invalidArgument(function, "target is null or target->struct_size not set");
        if (t.content != LSK_CONTENT_VIRTUAL_ONLY && t.content != LSK_CONTENT_COMPOSITE)
            return fail(LSK_ERROR_INVALID_ARGUMENT,
                        "lsk_render_target.content: " + std::to_string(t.content) + " is not an lsk_content");
        mr::RenderTarget r;
        r.framebuffer = t.framebuffer;
        r.texture = t.texture;
        r.x = t.x;
        r.y = t.y;
        r.width = t.width;
        r.height = t.height;
        r.content = t.content == LSK_CONTENT_COMPOSITE ? mr::RenderContent::CompositeOverCamera
                                                       : mr::RenderContent::VirtualOnly;
        r.depthTest = t.depth_test != 0;
        r.nearMetres = t.near_metres;
        r.farMetres = t.far_metres;
        s.render(r);
        return LSK_OK;
    });
}

lsk_status lsk_session_projection(const lsk_session* session, double nearMetres, double farMetres, float out[16]) {
    constexpr const char* function = "lsk_session_projection";
    return guardedSession(function, session, [&](const mr::Session& s) -> lsk_status {
        if (out == nullptr) return invalidArgument(function, "out is null");
        if (!(nearMetres > 0.0 && farMetres > nearMetres))
            return invalidArgument(function, "needs 0 < near_metres < far_metres");
        const glm::mat4 m = s.projection(nearMetres, farMetres);
        std::memcpy(out, glm::value_ptr(m), 16 * sizeof(float));
        return LSK_OK;
    });
}

lsk_status lsk_session_read_composite(const lsk_session* session, uint8_t* rgb, size_t rowBytes) {
    constexpr const char* function = "lsk_session_read_composite";
    return guardedSession(function, session, [&](const mr::Session& s) -> lsk_status {
        if (rgb == nullptr) return invalidArgument(function, "rgb is null");
        const cv::Mat& composite = s.output().withGi;
        if (composite.empty())
            return fail(LSK_ERROR_INPUT, std::string(function) + ": no frame has been processed yet");
        const std::size_t step = rowBytes != 0 ? rowBytes : std::size_t(composite.cols) * 3;
        if (step < std::size_t(composite.cols) * 3)
            return invalidArgument(function, "row_bytes smaller than a row (width * 3)");
        cv::Mat out(composite.rows, composite.cols, CV_8UC3, rgb, step); // a header: cvtColor writes in place
        cv::cvtColor(composite, out, cv::COLOR_BGR2RGB);
        return LSK_OK;
    });
}

lsk_status lsk_session_camera(const lsk_session* session, lsk_camera* out) {
    constexpr const char* function = "lsk_session_camera";
    return guardedSession(function, session, [&](const mr::Session& s) -> lsk_status {
        if (out == nullptr) return invalidArgument(function, "out is null");
        const lightskin::CameraIntrinsics& k = s.camera();
        *out = lsk_camera{k.width, k.height, k.fx, k.fy, k.cx, k.cy};
        return LSK_OK;
    });
}

lsk_status lsk_session_view(const lsk_session* session, float out[16]) {
    constexpr const char* function = "lsk_session_view";
    return guardedSession(function, session, [&](const mr::Session& s) -> lsk_status {
        if (out == nullptr) return invalidArgument(function, "out is null");
        const glm::mat4 m = s.viewMatrix();
        std::memcpy(out, glm::value_ptr(m), 16 * sizeof(float));
        return LSK_OK;
    });
}

lsk_status lsk_session_set_budget(lsk_session* session, double budgetMs) {
    constexpr const char* function = "lsk_session_set_budget";
    return guardedSession(function, session, [&](mr::Session& s) -> lsk_status {
        if (!(budgetMs > 0.0)) return invalidArgument(function, "budget_ms must be > 0");
        s.setBudgetMs(budgetMs);
        return LSK_OK;
    });
}

lsk_status lsk_session_technique(const lsk_session* session, int32_t* technique, int32_t* backend) {
    constexpr const char* function = "lsk_session_technique";
    return guardedSession(function, session, [&](const mr::Session& s) -> lsk_status {
        const mr::FrameReport& r = s.report();
        const bool ran = r.frameIndex >= 0;
        const gi::Technique t = ran ? r.technique : s.pipeline().technique();
        const gi::Backend b = ran ? r.backend : s.pipeline().backend();
        if (technique != nullptr) *technique = techniqueOf(t);
        if (backend != nullptr) *backend = b == gi::Backend::Cpu ? LSK_BACKEND_CPU : LSK_BACKEND_GL;
        return LSK_OK;
    });
}

void lsk_material_init(lsk_material* material) {
    if (material == nullptr) return;
    *material = lsk_material{};
    material->struct_size = sizeof(lsk_material);
}

lsk_status lsk_session_object_count(const lsk_session* session, uint32_t* count) {
    constexpr const char* function = "lsk_session_object_count";
    return guardedSession(function, session, [&](const mr::Session& s) -> lsk_status {
        if (count == nullptr) return invalidArgument(function, "count is null");
        *count = uint32_t(s.scene().objects.size());
        return LSK_OK;
    });
}

lsk_status lsk_session_object_name(const lsk_session* session, uint32_t index, const char** name) {
    constexpr const char* function = "lsk_session_object_name";
    return guardedSession(function, session, [&](const mr::Session& s) -> lsk_status {
        if (name == nullptr) return invalidArgument(function, "name is null");
        const auto& objects = s.scene().objects;
        if (index >= objects.size())
            return invalidArgument(function, "object " + std::to_string(index) + ": no such object (the scene has " +
                                                 std::to_string(objects.size()) + ")");
        *name = objects[index].name.c_str();
        return LSK_OK;
    });
}

lsk_status lsk_session_object_transform(const lsk_session* session, uint32_t index, float out[16]) {
    constexpr const char* function = "lsk_session_object_transform";
    return guardedSession(function, session, [&](const mr::Session& s) -> lsk_status {
        if (out == nullptr) return invalidArgument(function, "out is null");
        const auto& objects = s.scene().objects;
        if (index >= objects.size())
            return invalidArgument(function, "object " + std::to_string(index) + ": no such object (the scene has " +
                                                 std::to_string(objects.size()) + ")");
        std::memcpy(out, glm::value_ptr(objects[index].world_T_model), 16 * sizeof(float));
        return LSK_OK;
    });
}

lsk_status lsk_session_light_count(const lsk_session* session, uint32_t* count) {
    constexpr const char* function = "lsk_session_light_count";
    return guardedSession(function, session, [&](const mr::Session& s) -> lsk_status {
        if (count == nullptr) return invalidArgument(function, "count is null");
        *count = uint32_t(s.scene().lights.size());
        return LSK_OK;
    });
}

lsk_status lsk_session_set_object_transform(lsk_session* session, uint32_t index, const float world_T_model[16]) {
    constexpr const char* function = "lsk_session_set_object_transform";
    return guardedSession(function, session, [&](mr::Session& s) -> lsk_status {
        if (world_T_model == nullptr) return invalidArgument(function, "world_T_model is null");
        s.setObjectTransform(index, glm::make_mat4(world_T_model));
        return LSK_OK;
    });
}

lsk_status lsk_session_set_object_visible(lsk_session* session, uint32_t index, int32_t visible) {
    constexpr const char* function = "lsk_session_set_object_visible";
    return guardedSession(function, session, [&](mr::Session& s) -> lsk_status {
        if (visible != 0 && visible != 1) return invalidArgument(function, "visible must be 0 or 1");
        s.setObjectVisible(index, visible == 1);
        return LSK_OK;
    });
}

lsk_status lsk_session_set_object_material(lsk_session* session, uint32_t index, const lsk_material* material) {
    constexpr const char* function = "lsk_session_set_object_material";
    return guardedSession(function, session, [&](mr::Session& s) -> lsk_status {
        lsk_material m{};
        if (!readVersioned(material, m)) return invalidArgument(function, "material is null or struct_size not set");
        lightskin::render::MaterialOverride o;
        if (m.set_diffuse != 0) o.diffuseAlbedo = glm::make_vec3(m.diffuse_albedo);
        if (m.set_specular != 0) o.specularAlbedo = glm::make_vec3(m.specular_albedo);
        if (m.specular_exponent != 0.0f) o.specularExponent = m.specular_exponent;
        s.setObjectMaterial(index, o);
        return LSK_OK;
    });
}

lsk_status lsk_session_set_light(lsk_session* session, uint32_t index, const float position[3],
                                 const float direction[3], const float power[3]) {
    constexpr const char* function = "lsk_session_set_light";
    return guardedSession(function, session, [&](mr::Session& s) -> lsk_status {
        if (position == nullptr || power == nullptr)
            return invalidArgument(function, "position and power must not be null");
        const glm::vec3 d = direction != nullptr ? glm::make_vec3(direction) : glm::vec3(0.0f, 0.0f, -1.0f);
        s.setLight(index, glm::make_vec3(position), d, glm::make_vec3(power));
        return LSK_OK;
    });
}

lsk_status lsk_session_add_object(lsk_session* session, const char* meshPath, const char* name,
                                  const float world_T_model[16], uint32_t* index) {
    constexpr const char* function = "lsk_session_add_object";
    return guardedSession(function, session, [&](mr::Session& s) -> lsk_status {
        if (meshPath == nullptr || *meshPath == '\0') return invalidArgument(function, "mesh_path is null or empty");
        if (name == nullptr || *name == '\0') return invalidArgument(function, "name is null or empty");
        lightskin::render::SceneObject object;
        object.name = name;
        object.mesh = std::filesystem::absolute(meshPath);
        if (world_T_model != nullptr) object.world_T_model = glm::make_mat4(world_T_model);
        const std::size_t added = s.addObject(std::move(object));
        if (index != nullptr) *index = uint32_t(added);
        return LSK_OK;
    });
}

lsk_status lsk_session_remove_object(lsk_session* session, uint32_t index) {
    constexpr const char* function = "lsk_session_remove_object";
    return guardedSession(function, session, [&](mr::Session& s) -> lsk_status {
        s.removeObject(index);
        return LSK_OK;
    });
}

lsk_status lsk_session_save_room_model(lsk_session* session, const char* path) {
    constexpr const char* function = "lsk_session_save_room_model";
    return guardedSession(function, session, [&](mr::Session& s) -> lsk_status {
        if (path == nullptr || *path == '\0') return invalidArgument(function, "path is null or empty");
        s.saveRoomModel(path);
        return LSK_OK;
    });
}

lsk_status lsk_session_load_room_model(lsk_session* session, const char* path) {
    constexpr const char* function = "lsk_session_load_room_model";
    return guardedSession(function, session, [&](mr::Session& s) -> lsk_status {
        if (path == nullptr || *path == '\0') return invalidArgument(function, "path is null or empty");
        s.loadRoomModel(path);
        return LSK_OK;
    });
}

} // extern "C"
