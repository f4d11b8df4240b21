#include <lightskin/gi/common/Technique.h>

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

bool runsOn(Technique technique, Backend backend) noexcept {
    return backend == Backend::Gl || technique == Technique::LightSkin;
}

} // namespace lightskin::gi
