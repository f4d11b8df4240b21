#pragma once
// The names of the indirect-illumination techniques and of the backends they run on: one spelling each,
// used by scene files, the command line, benchmarks, reports and the C ABI. The techniques themselves,
// their settings and the factory are in lightskin/gi/Techniques.h (the registry).

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace lightskin::gi {

enum class Technique : std::uint8_t {
    LightSkin,        ///< "lightskin": sparse gather + interpolation (gi/lightskin)
    BruteForce,       ///< "brute-force": every VAL at every pixel (gi/bruteforce)
    ImperfectVolumes, ///< "imperfect-volumes" (gi/volumes)
    MultiscalePrt,    ///< "multiscale-prt" (gi/prt)
    None,             ///< "none": no indirect light
};

/// Where a technique's per-frame stages run; its shading pass is GL in every case.
enum class Backend : std::uint8_t {
    Gl,  ///< "gl": OpenGL 4.5 passes
    Cpu, ///< "cpu": SIMD + threads on the CPU
};

inline constexpr std::array kTechniques{Technique::LightSkin, Technique::BruteForce, Technique::ImperfectVolumes,
                                        Technique::MultiscalePrt, Technique::None};
inline constexpr std::array kBackends{Backend::Gl, Backend::Cpu};

/// The technique's one spelling ("lightskin", "brute-force", "imperfect-volumes", "multiscale-prt", "none").
std::string_view toString(Technique technique) noexcept;
/// The backend's one spelling ("gl", "cpu").
std::string_view toString(Backend backend) noexcept;
/// The technique or backend of that exact spelling; nullopt for any other text.
std::optional<Technique> parseTechnique(std::string_view name) noexcept;
std::optional<Backend> parseBackend(std::string_view name) noexcept;
/// For error messages: "\"lightskin\", \"brute-force\", ... or \"none\"" (quoted) or without the quotes.
std::string techniqueNames(bool quoted);
std::string backendNames(bool quoted);

/// Whether `technique` runs on `backend`: every technique on gl, LightSkin on cpu too.
bool runsOn(Technique technique, Backend backend) noexcept;

/// What a scene's gi.backend or a command line's --backend asks for: a backend, or Auto (the scene's default),
/// which a pipeline resolves once, when it is created, by its GL renderer (chooseBackend).
enum class BackendSetting : std::uint8_t {
    Auto, ///< "auto": the CPU backend on a software rasterizer, else gl (chooseBackend)
    Gl,   ///< "gl"
    Cpu,  ///< "cpu"
};
inline constexpr std::array kBackendSettings{BackendSetting::Auto, BackendSetting::Gl, BackendSetting::Cpu};
/// "auto", "gl", "cpu".
std::string_view toString(BackendSetting setting) noexcept;
/// The setting of that exact spelling; nullopt for any other text.
std::optional<BackendSetting> parseBackendSetting(std::string_view name) noexcept;
/// For error messages: "\"auto\", \"gl\" or \"cpu\"" (quoted) or without the quotes.
std::string backendSettingNames(bool quoted);
/// The setting that names `backend` (never Auto).
BackendSetting settingOf(Backend backend) noexcept;

/// What kind of renderer a GL context's GL_RENDERER string names.
enum class GlRenderer : std::uint8_t {
    SoftwareRasterizer, ///< rasterises on the CPU: Mesa's llvmpipe, softpipe, swrast (also under zink), and the
                        ///< like of other systems (SwiftShader, WARP, GDI Generic, Apple Software Renderer)
    Gpu,                ///< anything else that names itself: a GPU, or a virtual one passing GL to the host's GPU
                        ///< (VMware SVGA3D, virgl)
    Unknown,            ///< an empty string: the driver does not say
};
/// Classifies GL_RENDERER (case-insensitively, by the names above anywhere in it).
GlRenderer classifyGlRenderer(std::string_view glRenderer) noexcept;

/// Why a pipeline's technique runs on the backend it runs on (BackendChoice).
enum class BackendReason : std::uint8_t {
    SceneSetting,          ///< the scene's gi.backend named the backend
    CommandLine,           ///< the pipeline's override named it (`lightskin replay --backend`, a host's option)
    SoftwareRasterizer,    ///< auto on a software rasterizer: the CPU backend (measured 3.3x faster on llvmpipe)
    Gpu,                   ///< auto on a GPU: gl
    UnknownRenderer,       ///< auto with an empty GL_RENDERER: gl, the backend of every technique
    TechniqueRunsOnlyOnGl, ///< the technique has no CPU backend (runsOn): gl, whatever was asked
};
/// One stable sentence per reason, for reports and `lightskin doctor`, e.g. "auto: the GL renderer is a
/// software rasterizer (llvmpipe, softpipe, swrast), on which the CPU backend is faster".
std::string_view toString(BackendReason reason) noexcept;

/// The backend a pipeline's technique runs on, and why.
struct BackendChoice {
    Backend backend = Backend::Gl;
    BackendReason reason = BackendReason::SceneSetting;
    friend bool operator==(const BackendChoice&, const BackendChoice&) = default;
};

/// The backend for `technique`: the command line's setting when there is one, else the scene's; Auto by the
/// renderer (the CPU backend on a software rasterizer, gl on a GPU or an unknown renderer). A technique that
/// does not run on the CPU (runsOn) gets gl whatever was asked. Auto does not measure the two backends: on a
/// GPU the GL path is the one made for it, and a timed trial would make the choice, and so the images,
/// depend on the machine's load (docs/SCENE_FORMAT.md, gi.backend).
BackendChoice chooseBackend(Technique technique, BackendSetting scene, std::optional<BackendSetting> commandLine,
                            GlRenderer renderer) noexcept;

} // namespace lightskin::gi
