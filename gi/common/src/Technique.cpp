#include <lightskin/gi/common/Technique.h>

#include <algorithm>
#include <cctype>
#include <span>

namespace lightskin::gi {

std::string_view toString(Technique technique) noexcept {
    switch (technique) {
    case Technique::LightSkin:
        return "lightskin";
    case Technique::BruteForce:
        return "brute-force";
    case Technique::ImperfectVolumes:
        return "imperfect-volumes";
    case Technique::MultiscalePrt:
        return "multiscale-prt";
    case Technique::None:
        return "none";
    }
    return "?";
}

std::string_view toString(Backend backend) noexcept {
    switch (backend) {
    case Backend::Gl:
        return "gl";
    case Backend::Cpu:
        return "cpu";
    }
    return "?";
}

std::optional<Technique> parseTechnique(std::string_view name) noexcept {
    for (const Technique t : kTechniques)
        if (toString(t) == name) return t;
    return std::nullopt;
}

std::optional<Backend> parseBackend(std::string_view name) noexcept {
    for (const Backend b : kBackends)
        if (toString(b) == name) return b;
    return std::nullopt;
}

std::string_view toString(BackendSetting setting) noexcept {
    switch (setting) {
    case BackendSetting::Auto:
        return "auto";
    case BackendSetting::Gl:
        return toString(Backend::Gl);
    case BackendSetting::Cpu:
        return toString(Backend::Cpu);
    }
    return "?";
}

std::optional<BackendSetting> parseBackendSetting(std::string_view name) noexcept {
    for (const BackendSetting s : kBackendSettings)
        if (toString(s) == name) return s;
    return std::nullopt;
}

BackendSetting settingOf(Backend backend) noexcept {
    return backend == Backend::Cpu ? BackendSetting::Cpu : BackendSetting::Gl;
}

GlRenderer classifyGlRenderer(std::string_view glRenderer) noexcept {
    if (glRenderer.find_first_not_of(" \t") == std::string_view::npos) return GlRenderer::Unknown;
    // In lower case, parts of the strings the drivers print: "llvmpipe (LLVM 15.0.6, 256 bits)", "softpipe",
    // "Software Rasterizer" (swrast's GL_RENDERER; "swrast" in driver names), "zink Vulkan 1.3(llvmpipe ...)",
    // "Google SwiftShader", "D3D12 (Microsoft Basic Render Driver)" (WARP), "GDI Generic" (Windows' GL 1.1),
    // "Apple Software Renderer". A GPU's string may name LLVM (AMD's shader compiler): not a match.
    static constexpr std::array<std::string_view, 8> kSoftware{
        "llvmpipe",    "softpipe",      "swrast", "software rasterizer", "swiftshader", "basic render driver",
        "gdi generic", "apple software"};
    const auto lower = [](char c) { return char(std::tolower(static_cast<unsigned char>(c))); };
    for (const std::string_view name : kSoftware) {
        const auto found = std::search(glRenderer.begin(), glRenderer.end(), name.begin(), name.end(),
                                       [&](char a, char b) { return lower(a) == b; });
        if (found != glRenderer.end()) return GlRenderer::SoftwareRasterizer;
    }
    return GlRenderer::Gpu;
}

std::string_view toString(BackendReason reason) noexcept {
    switch (reason) {
    case BackendReason::SceneSetting:
        return "the scene's gi.backend";
    case BackendReason::CommandLine:
        return "the command line's --backend (the pipeline's backend override)";
    case BackendReason::SoftwareRasterizer:
        return "auto: the GL renderer is a software rasterizer (llvmpipe, softpipe, swrast), on which the CPU "
               "backend is faster";
    case BackendReason::Gpu:
        return "auto: the GL renderer is a GPU";
    case BackendReason::UnknownRenderer:
        return "auto: the GL renderer does not name itself (empty GL_RENDERER), so gl";
    case BackendReason::TechniqueRunsOnlyOnGl:
        return "the technique runs on gl only (the CPU backend is LightSkin's)";
    }
    return "?";
}

BackendChoice chooseBackend(Technique technique, BackendSetting scene, std::optional<BackendSetting> commandLine,
                            GlRenderer renderer) noexcept {
    const BackendSetting asked = commandLine.value_or(scene);
    const BackendReason named = commandLine ? BackendReason::CommandLine : BackendReason::SceneSetting;
    if (asked == BackendSetting::Gl) return {Backend::Gl, named};
    if (!runsOn(technique, Backend::Cpu)) return {Backend::Gl, BackendReason::TechniqueRunsOnlyOnGl};
    if (asked == BackendSetting::Cpu) return {Backend::Cpu, named};
    switch (renderer) {
    case GlRenderer::SoftwareRasterizer:
        return {Backend::Cpu, BackendReason::SoftwareRasterizer};
    case GlRenderer::Gpu:
        return {Backend::Gl, BackendReason::Gpu};
    case GlRenderer::Unknown:
        break;
    }
    return {Backend::Gl, BackendReason::UnknownRenderer};
}

namespace {
template <class Enum, std::size_t N>
std::string nameList(const std::array<Enum, N>& values, bool quoted) {
    std::string out;
    for (std::size_t i = 0; i < N; ++i) {
        if (i > 0) out += i + 1 == N ? " or " : ", ";
        const std::string_view name = toString(values[i]);
        out += quoted ? "\"" + std::string(name) + "\"" : std::string(name);
    }
    return out;
}
} // namespace

std::string techniqueNames(bool quoted) { return nameList(kTechniques, quoted); }
std::string backendNames(bool quoted) { return nameList(kBackends, quoted); }
std::string backendSettingNames(bool quoted) { return nameList(kBackendSettings, quoted); }

bool runsOn(Technique technique, Backend backend) noexcept {
    return backend == Backend::Gl || technique == Technique::LightSkin;
}

} // namespace lightskin::gi
