#pragma once
// The registry of indirect-illumination techniques: the scene's GI settings, each technique's typed
// settings and the one factory. Names and backends: lightskin/gi/common/Technique.h. A technique lives
// in its own folder (gi/<folder>/); adding one touches that folder, Technique.h and this registry.

#include <lightskin/core/JsonReader.h>
#include <lightskin/gi/bruteforce/BruteForceIllumination.h>
#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gi/common/SparsePointSampler.h>
#include <lightskin/gi/common/Technique.h>
#include <lightskin/gi/lightskin/LightSkinIllumination.h>
#include <lightskin/gi/prt/MultiscalePrt.h>
#include <lightskin/gi/volumes/ImperfectVolumes.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace lightskin::gi {

/// The scene file's "gi" object (docs/SCENE_FORMAT.md), as render::loadScene reads it.
struct GiSettings {
    Technique technique = Technique::LightSkin;
    /// Where the technique's per-frame stages run: gl, cpu (runsOn(technique, Backend::Cpu) holds) or auto, which
    /// a pipeline resolves by its GL renderer (chooseBackend: the CPU backend on a software rasterizer); the
    /// pipeline keeps the setting as given and reports what it chose (mr::FramePipeline::backendChoice).
    BackendSetting backend = BackendSetting::Auto;
    int sparsePoints = 4096; ///< sparse scene points per mesh (paper: 4k or 16k), LightSkin
    int valStride = 4;       ///< one VAL per valStride x valStride depth pixels
    int kCache = 128;        ///< the paper's K_cache (VALs per cache block), LightSkin and the brute force
    bool diffuse = true;
    bool glossy = true;
    bool occlusion = true;
    /// One bounce between virtual objects: per frame, a reflective shadow map of the virtual
    /// meshes per scene light gives VALs (gi::ReflectiveShadowMap) that are merged after the
    /// depth VALs. Off by default: opt-in, so existing scenes keep their images and frame times.
    bool virtualBounce = false;
    int rsmResolution = 64; ///< RSM texels per side per light face (spot: 1 face, point: 6)
    /// Frame-time budget in milliseconds ("budgetMs"; 0 = none): a mr::Session then picks technique,
    /// sparse points, VAL stride and channels per frame to meet it (mr/FrameBudget.h).
    double budgetMs = 0.0;
    /// The light model for real depth (docs/LIGHTSKIN.md, guards G10-G12): on by default; false = the
    /// plain model, for measurement (`lightskin bench-realdepth`).
    bool robustRealDepth = true;
    /// LightSkin's gather with a cut through the VAL tree (LightSkinSettings::valTreeThreshold, both
    /// backends): 0 = the flat gather over every VAL. Empty ("auto", the default): where the cut is measured to
    /// pay, see configFor.
    std::optional<float> valTreeThreshold;
    /// Not a scene key: with robustRealDepth, false drops only the vertex irradiance cap (guard G10), for
    /// measurement (`lightskin bench-realdepth --models robust-nocap`).
    bool robustIrradianceCap = true;
    /// Not a scene key: with robustRealDepth, false drops only the rule for sparse points buried under the
    /// real surface (guard G11), for measurement (`--models robust-noburied`).
    bool robustBuriedSparsePoints = true;
    /// Not a scene key: with robustRealDepth, true adds near-field VALs as areas (guard G12; `--models
    /// robust-area`). Off by default: on llvmpipe it makes the gather ~3x and the brute force ~4x slower
    /// for no measured gain on the bundled real recordings (docs/BENCHMARKS.md).
    bool robustNearField = false;
    /// Technique "imperfect-volumes": the "imperfectVolumes" object.
    ImperfectVolumesSettings imperfectVolumes;
    /// Technique "multiscale-prt": the "multiscalePrt" object. Its cacheDirectory is "prt-cache" beside the
    /// scene file unless the scene says otherwise (empty for scenes parsed from text).
    MultiscalePrtSettings multiscalePrt;
};

/// A pipeline's run-time options for LightSkin (mr::PipelineOptions: --adaptive and its knobs).
struct AdaptiveOptions {
    bool on = false;
    float staticTolerance = 0.0f;
    StaticChangeTest staticChangeTest = StaticChangeTest::Bound;
};

/// Every technique's typed settings; createTechnique() reads those of `technique`.
struct TechniqueConfig {
    Technique technique = Technique::LightSkin;
    Backend backend = Backend::Gl;
    LightSkinSettings lightSkin; ///< LightSkin on either backend
    int cpuThreads = 0;          ///< LightSkin on the CPU: worker threads (0 = all)
    BruteForceSettings bruteForce;
    ImperfectVolumesSettings imperfectVolumes;
    MultiscalePrtSettings multiscalePrt;
    /// The scene lights, for the techniques that light the virtual objects themselves: imperfect volumes'
    /// mesh points (with the renderer's shadow cube maps, 0 = unshadowed) and multi-scale PRT's entry points.
    std::vector<VolumeLight> volumeLights;
    std::uint32_t volumeShadowCubes = 0;
    std::vector<PrtLight> prtLights;
};

/// The scene's "gi" object (`value` at JSON pointer `pointer`, usually "/gi"): the common keys here, each
/// technique's own object by that technique's reader (volumes/ImperfectVolumesJson.h, prt/MultiscalePrtJson.h).
/// Throws lightskin::Error naming the key.
GiSettings readGiSettings(const JsonReader& reader, const nlohmann::json& value, const std::string& pointer);

/// The typed settings the scene's "gi" object means (LightSkin's guards from robustRealDepth and the rest),
/// with the pipeline's adaptive options. A backend still "auto" is gl here: only a pipeline, which knows its GL
/// renderer, resolves auto (chooseBackend). An automatic valTreeThreshold cuts at kAutoValTreeThreshold on gl in
/// frames of at least kGlValTreeMinVals VALs (measured crossover on llvmpipe: the flat gather is cheaper below) and
/// never on the CPU backend, whose scalar walk of the cut was slower than its SIMD flat gather up to 217k VALs
/// (docs/BENCHMARKS.md "VAL tree: where it pays").
inline constexpr float kAutoValTreeThreshold = 0.05f;
inline constexpr std::uint32_t kGlValTreeMinVals = 10000;
TechniqueConfig configFor(const GiSettings& settings, const AdaptiveOptions& adaptive = {});

/// The one factory: a technique of config.technique, on config.backend where it runs on it (runsOn), else
/// on gl (a frame budget switching a CPU LightSkin to the brute force keeps the backend for its way back).
/// `sparsePoints` supplies the sparse points of every mesh to the techniques whose capabilities() say
/// sparsePoints (it must outlive them). Needs a current GL 4.5 context. Throws lightskin::Error on bad
/// settings.
std::unique_ptr<IndirectIllumination> createTechnique(const TechniqueConfig& config, SparsePointProvider sparsePoints);

/// Whether the technique needs the renderer to prepare sparse points of every mesh.
bool needsSparsePoints(Technique technique) noexcept;

/// Multi-scale PRT's last prepare() statistics, when `technique` is that technique.
std::optional<PrtPrepareStats> prtPrepareStatsOf(const IndirectIllumination& technique);

} // namespace lightskin::gi
