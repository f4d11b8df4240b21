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

} // namespace lightskin::gi
