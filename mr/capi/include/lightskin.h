/* lightskin C ABI (C11): the mixed-reality pipeline for hosts in C, C#, Python (ctypes), engines.
 *
 * Library: liblightskin.so (SONAME liblightskin.so.<major>.<minor> while the major version is 0);
 * it exports only the lsk_* functions below. Find it with pkg-config (lightskin.pc) or CMake
 * (find_package(lightskin), target lightskin::lightskin).
 *
 * Objects: an lsk_session is opaque, created by lsk_session_create*() and destroyed by
 * lsk_session_destroy(); the library owns it. Every other struct is plain data owned by the
 * caller, passed by pointer, and starts with `struct_size`: set it to sizeof(the struct) as your
 * header defines it (the *_init() functions do this and fill the defaults). The library reads only
 * the fields that lie within struct_size and writes only those, so a host built against an older
 * header keeps working with a newer library (fields are only ever appended).
 *
 * Errors: every function that can fail returns an lsk_status; on failure lsk_last_error() gives
 * the reason (naming the file, frame or field) as text. No C++ exception crosses this interface.
 *
 * Threading and GL: a session belongs to one thread at a time; distinct sessions may run on
 * distinct threads. The host creates and owns the OpenGL 4.5 core context: every lsk_session_*
 * call except lsk_session_report() needs that context current on the calling thread (the same
 * context, or one sharing objects with it, for the session's whole life, including destroy).
 * The session leaves the GL state as it found it: framebuffer, program, vertex array, buffer,
 * texture, sampler and image bindings, viewport, scissor, blend, depth, cull, colour mask, pixel
 * store (docs/PLUGIN.md lists them). lsk_last_error() is per thread.
 *
 * Units and frames: metres; the camera frame is OpenCV's (x right, y down, z forward); poses are
 * world_T_camera 4x4 matrices, column-major (like OpenGL and glm); colour images are sRGB-encoded.
 */
#ifndef LIGHTSKIN_H
#define LIGHTSKIN_H

#include <stddef.h>
#include <stdint.h>

#if defined(LSK_BUILDING_LIBRARY)
#define LSK_API __attribute__((visibility("default")))
#else
#define LSK_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

#define LSK_VERSION_MAJOR 0
#define LSK_VERSION_MINOR 3
#define LSK_VERSION_PATCH 0

typedef enum lsk_status {
    LSK_OK = 0,
    LSK_END_OF_STREAM = 1,           /* lsk_session_process_next(): the source has no more frames */
    LSK_ERROR_INVALID_ARGUMENT = -1, /* a null pointer, a struct_size too small, a value out of range */
    LSK_ERROR_INPUT = -2,            /* bad scene, recording, frame or render target (see lsk_last_error) */
    LSK_ERROR_OUT_OF_MEMORY = -3,
    LSK_ERROR_INTERNAL = -4 /* a bug in lightskin: please report lsk_last_error() */
} lsk_status;

typedef enum lsk_pose_mode {
    LSK_POSE_HOST = 0,     /* the host's pose (lsk_frame.world_T_camera) or the recording's ground truth */
    LSK_POSE_TRACKING = 1, /* AprilTag tracking with the scene's "tracking" object */
    LSK_POSE_FIXED = 2     /* the camera at the world origin */
} lsk_pose_mode;

/* LSK_TRACKING_DEPTH: the tags failed and the pose came from depth against the scene's "roomModel". */
typedef enum lsk_tracking_state {
    LSK_TRACKING = 0,
    LSK_TRACKING_HELD = 1,
    LSK_TRACKING_LOST = 2,
    LSK_TRACKING_DEPTH = 3
} lsk_tracking_state;
/* The GI techniques (scene gi.technique: "lightskin", "brute-force", "imperfect-volumes", "multiscale-prt",
 * "none") and the backends they run on (gi.backend: "gl", "cpu", or "auto", the default: the CPU on a software
 * rasterizer such as llvmpipe, else GL; only LightSkin runs on the CPU). Values are
 * never renumbered: new ones are appended. */
typedef enum lsk_technique {
    LSK_TECHNIQUE_LIGHTSKIN = 0,
    LSK_TECHNIQUE_BRUTE_FORCE = 1,
    LSK_TECHNIQUE_IMPERFECT_VOLUMES = 2, /* since 0.2 */
    LSK_TECHNIQUE_MULTISCALE_PRT = 3,    /* since 0.2 */
    LSK_TECHNIQUE_NONE = 4               /* since 0.2: direct light only */
} lsk_technique;
typedef enum lsk_backend { LSK_BACKEND_GL = 0, LSK_BACKEND_CPU = 1 } lsk_backend; /* since 0.2 */

typedef enum lsk_content {
    LSK_CONTENT_VIRTUAL_ONLY = 0, /* lit virtual objects over what the target holds (uncovered pixels untouched) */
    LSK_CONTENT_COMPOSITE = 1     /* camera image + virtual objects (occluded by real depth), whole viewport */
} lsk_content;

/* Pinhole intrinsics of the colour camera, pixels (no distortion through this interface). */
typedef struct lsk_camera {
    int32_t width, height;
    double fx, fy, cx, cy;
} lsk_camera;

typedef struct lsk_session_options {
    uint32_t struct_size;
    int32_t pose_mode;  /* lsk_pose_mode; default LSK_POSE_HOST */
    int32_t gi_enabled; /* 1 = global illumination on (default), 0 = direct light only */
    double budget_ms;   /* frame-time budget, ms; 0 = the scene's gi.budgetMs (default), if any */
} lsk_session_options;

/* The scene: a file path, or JSON text plus the folder its relative mesh paths start from. */
typedef struct lsk_scene {
    uint32_t struct_size;
    const char* path;        /* scene file (docs/SCENE_FORMAT.md), or NULL */
    const char* json;        /* or the scene as JSON text */
    const char* base_folder; /* for json: folder of relative paths (NULL = current directory) */
} lsk_scene;

/* A frame in host memory; read during lsk_session_submit() only. */
typedef struct lsk_frame {
    uint32_t struct_size;
    const uint8_t* rgb;        /* width*height*3 bytes, R,G,B, sRGB-encoded, top row first */
    size_t rgb_row_bytes;      /* 0 = width*3 */
    const uint16_t* depth;     /* optional (NULL = none: no GI light, no real occlusion): z along the optical
                                  axis in depth_scale_metres units, 0 = missing, registered to rgb */
    size_t depth_row_bytes;    /* 0 = width*2 */
    double depth_scale_metres; /* e.g. 0.001 for millimetres */
    lsk_camera camera;         /* must equal the session's camera */
    double timestamp_seconds;
    int32_t has_pose;          /* 1: world_T_camera is the host's pose of the colour camera */
    double world_T_camera[16]; /* column-major, metres, OpenCV camera frame */
} lsk_frame;

#define LSK_MAX_STAGES 16
typedef struct lsk_stage_time {
    char name[32]; /* e.g. "depth filter", "pose", "vals", "gbuffer+gi", "shade+composite" */
    double cpu_ms; /* wall clock, ms */
} lsk_stage_time;

typedef struct lsk_frame_report {
    uint32_t struct_size;
    int64_t frame_index;
    double timestamp_seconds;
    int32_t tracking_state; /* lsk_tracking_state */
    int32_t has_pose;
    double world_T_camera[16]; /* column-major (valid when has_pose) */
    uint32_t val_count;        /* virtual area lights made from depth */
    int64_t covered_pixels;    /* pixels covered by virtual content */
    double total_ms;           /* wall clock of the frame */
    uint32_t stage_count;
    lsk_stage_time stages[LSK_MAX_STAGES];
    /* The GI settings this frame ran with (chosen by the budget when one is active). */
    int32_t technique;     /* the frame budget's choice: LIGHTSKIN or BRUTE_FORCE (lsk_session_technique: the technique) */
    int32_t sparse_points; /* per object (LightSkin) */
    int32_t val_stride;
    int32_t glossy, occlusion;
    int32_t budget_active;
    double budget_ms, predicted_ms, expected_error;
} lsk_frame_report;

typedef struct lsk_render_target {
    uint32_t struct_size;
    uint32_t framebuffer;  /* GL framebuffer name (0 = default framebuffer) ... */
    uint32_t texture;      /* ... or, when non-zero, a colour-renderable GL_TEXTURE_2D (level 0) */
    int32_t x, y;          /* viewport origin (GL: bottom left) */
    int32_t width, height; /* viewport size; 0 = the camera's size */
    int32_t content;       /* lsk_content; default LSK_CONTENT_VIRTUAL_ONLY */
    int32_t depth_test;    /* virtual only, framebuffer with depth: test/write depth with lsk_session_projection() */
    double near_metres, far_metres; /* of that projection; defaults 0.05, 20 */
} lsk_render_target;

/* Since 0.3: a material change (lsk_session_set_object_material); unset values keep the mesh file's. */
typedef struct lsk_material {
    uint32_t struct_size;
    int32_t set_diffuse;      /* 1 = diffuse_albedo applies */
    float diffuse_albedo[3];  /* linear RGB in [0, 1] */
    int32_t set_specular;     /* 1 = specular_albedo applies */
    float specular_albedo[3]; /* linear RGB in [0, 1] */
    float specular_exponent;  /* Phong exponent >= 1; 0 = the mesh file's */
} lsk_material;

typedef struct lsk_session lsk_session;

/* "0.2.0"; compare with LSK_VERSION_* to detect a header/library mismatch. Never fails. */
LSK_API const char* lsk_version(void);
/* The last error on this thread ("" if none); valid until the next lsk_* call on this thread. */
LSK_API const char* lsk_last_error(void);

LSK_API void lsk_session_options_init(lsk_session_options* options);
LSK_API void lsk_scene_init(lsk_scene* scene);
LSK_API void lsk_frame_init(lsk_frame* frame);
LSK_API void lsk_frame_report_init(lsk_frame_report* report);
LSK_API void lsk_render_target_init(lsk_render_target* target);
LSK_API void lsk_material_init(lsk_material* material); /* since 0.3: nothing set */

/* A session fed by the host (lsk_session_submit) for frames of `camera`. */
LSK_API lsk_status lsk_session_create(const lsk_session_options* options, const lsk_scene* scene,
                                      const lsk_camera* camera, lsk_session** out);
/* A session fed by a recording or device (lsk_session_process_next): a lightskin recording folder,
 * a TUM RGB-D folder, an .oni file, "openni2://", "freenect://". */
LSK_API lsk_status lsk_session_create_from_source(const lsk_session_options* options, const lsk_scene* scene,
                                                  const char* source_uri, lsk_session** out);
/* NULL is ignored. Needs the session's GL context current. */
LSK_API void lsk_session_destroy(lsk_session* session);

LSK_API lsk_status lsk_session_process_next(lsk_session* session);
LSK_API lsk_status lsk_session_submit(lsk_session* session, const lsk_frame* frame);
/* Fills `report` (set report->struct_size first, e.g. with lsk_frame_report_init). No GL. */
LSK_API lsk_status lsk_session_report(const lsk_session* session, lsk_frame_report* report);
LSK_API lsk_status lsk_session_render(lsk_session* session, const lsk_render_target* target);

/* Copies the last frame's composite (camera image + lit virtual objects, occluded by real depth) into
 * host memory: width*height*3 bytes, R,G,B, sRGB-encoded, top row first; row_bytes 0 = width*3.
 * For hosts that display a CPU image. No GL. LSK_ERROR_INPUT before the first frame. */
LSK_API lsk_status lsk_session_read_composite(const lsk_session* session, uint8_t* rgb, size_t row_bytes);
/* The session's colour camera (a source-fed session: the source's). No GL. */
LSK_API lsk_status lsk_session_camera(const lsk_session* session, lsk_camera* out);
/* The session camera's GL projection (OpenCV camera frame in) and the last frame's camera_T_world,
 * both column-major: clip = projection * view * world point (for a host drawing its own geometry). */
LSK_API lsk_status lsk_session_projection(const lsk_session* session, double near_metres, double far_metres,
                                          float out[16]);
LSK_API lsk_status lsk_session_view(const lsk_session* session, float out[16]);
/* Sets the frame budget in ms (> 0); starts budget mode if the session had none. Needs no GL. */
LSK_API lsk_status lsk_session_set_budget(lsk_session* session, double budget_ms);
/* Since 0.2: the technique (lsk_technique) and backend (lsk_backend) the last frame ran, or the scene's before
 * the first frame. Either pointer may be NULL. No GL. */
LSK_API lsk_status lsk_session_technique(const lsk_session* session, int32_t* technique, int32_t* backend);

/* Since 0.3, moving content (docs/PLUGIN.md, "Moving content"). Objects and lights are numbered 0..count-1
 * in the scene's order; an added object comes last, removing one moves the later ones down by one. Each
 * call checks its input (an unknown index, a non-finite, singular or sheared matrix, a negative power,
 * a missing mesh file) and returns an error with lsk_last_error() naming the object or light and the
 * cause, changing nothing. Transforms and lights take effect from the next frame; an object's transform
 * or a light's values stop its scene animation (the host drives it from then on). Matrices are
 * world_T_model, column-major, metres: a rotation times one uniform scale, plus a translation.
 * Counts and names need no GL; visible, material, add and remove need the session's context current. */
LSK_API lsk_status lsk_session_object_count(const lsk_session* session, uint32_t* count);
/* The object's name; valid until the next add or remove. */
LSK_API lsk_status lsk_session_object_name(const lsk_session* session, uint32_t index, const char** name);
/* The object's world_T_model as the last frame placed it (after its animation), column-major. No GL. */
LSK_API lsk_status lsk_session_object_transform(const lsk_session* session, uint32_t index, float out[16]);
LSK_API lsk_status lsk_session_light_count(const lsk_session* session, uint32_t* count);
LSK_API lsk_status lsk_session_set_object_transform(lsk_session* session, uint32_t index,
                                                    const float world_T_model[16]);
/* visible: 1 = drawn, lit and lighting; 0 = as if absent (kept loaded). The GI is prepared again. */
LSK_API lsk_status lsk_session_set_object_visible(lsk_session* session, uint32_t index, int32_t visible);
LSK_API lsk_status lsk_session_set_object_material(lsk_session* session, uint32_t index, const lsk_material* material);
/* position: world metres; direction: spot lights only (normalised; ignored for point lights, may be NULL);
 * power: watts, linear RGB, >= 0. */
LSK_API lsk_status lsk_session_set_light(lsk_session* session, uint32_t index, const float position[3],
                                         const float direction[3], const float power[3]);
/* Loads a mesh file (OBJ, PLY, glTF; path absolute or relative to the working directory) as a new object
 * named `name` (not NULL, not empty), placed by world_T_model (NULL = identity); its index into *index
 * (may be NULL). The GI is prepared again for the new set of objects. */
LSK_API lsk_status lsk_session_add_object(lsk_session* session, const char* mesh_path, const char* name,
                                          const float world_T_model[16], uint32_t* index);
LSK_API lsk_status lsk_session_remove_object(lsk_session* session, uint32_t index);

/* Since 0.3: the room memory's model (a scene with a roomModel block, LSK_POSE_TRACKING, depth registered to colour;
 * docs/ROOMMODEL.md "Saving and loading"). save: writes it to `path` (not NULL), never over a file lightskin did not
 * write, replaced only when complete. load: replaces the model by a saved one of the same grid (a corrupt file or
 * another grid is an error naming the file, and the model stays as it was). Both stop a source-fed session's
 * read-ahead first: call them between frames; frames read ahead are dropped. No GL. */
LSK_API lsk_status lsk_session_save_room_model(lsk_session* session, const char* path);
LSK_API lsk_status lsk_session_load_room_model(lsk_session* session, const char* path);

#ifdef __cplusplus
}
#endif

#endif /* LIGHTSKIN_H */
