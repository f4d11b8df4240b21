#include <lightskin/core/Log.h>
#include <lightskin/gi/Techniques.h>
#include <lightskin/gi/common/NullIndirectIllumination.h>
#include <lightskin/gi/lightskin/CpuLightSkin.h>

#include <string>

namespace lightskin::gi {

TechniqueConfig configFor(const GiSettings& settings, const AdaptiveOptions& adaptive) {
    if (!settings.diffuse && settings.technique != Technique::None)
        log::warning("gi.diffuse = false is not supported by the techniques: the diffuse channel stays on");
    TechniqueConfig c;
    c.technique = settings.technique;
    c.backend = settings.backend == BackendSetting::Cpu ? Backend::Cpu : Backend::Gl;
    const bool robust = settings.robustRealDepth;
    LightSkinSettings& s = c.lightSkin;
    s.kCache = settings.kCache;
    s.glossy = settings.glossy;
    s.occlusion = settings.occlusion;
    s.vertexDistanceFloor = robust;
    s.extendedVplHorizon = robust;
    if (settings.valTreeThreshold) {
        s.valTreeThreshold = *settings.valTreeThreshold;
    } else if (c.backend == Backend::Gl) {
        s.valTreeThreshold = kAutoValTreeThreshold;
        s.valTreeMinVals = kGlValTreeMinVals;
    }
    s.vertexIrradianceCap = robust && settings.robustIrradianceCap;
    s.buriedSparsePoints = robust && settings.robustBuriedSparsePoints;
    s.nearFieldArea = robust && settings.robustNearField;
    if (adaptive.on) {
        s.adaptive = true;
        // The CPU backend takes the channel choices only: it has no static-content reuse.
        if (c.backend == Backend::Gl) {
            s.staticTolerance = adaptive.staticTolerance;
            s.staticChangeTest = adaptive.staticChangeTest;
        }
    }
    c.bruteForce.kCache = settings.kCache;
    c.bruteForce.glossy = settings.glossy;
    c.bruteForce.nearFieldArea = robust && settings.robustNearField;
    c.imperfectVolumes = settings.imperfectVolumes;
    c.multiscalePrt = settings.multiscalePrt;
    return c;
}

std::unique_ptr<IndirectIllumination> createTechnique(const TechniqueConfig& config, SparsePointProvider sparsePoints) {
    switch (config.technique) {
    case Technique::LightSkin:
        if (config.backend == Backend::Cpu) {
            CpuLightSkinSettings cpu;
            cpu.lightSkin = config.lightSkin;
            cpu.threads = config.cpuThreads;
            return CpuLightSkin::create(cpu, std::move(sparsePoints));
        }
        return LightSkinIllumination::create(config.lightSkin, std::move(sparsePoints));
    case Technique::BruteForce:
        return BruteForceIllumination::create(config.bruteForce);
    case Technique::ImperfectVolumes: {
        auto volumes = ImperfectVolumes::create(config.imperfectVolumes);
        volumes->setDirectLights(config.volumeLights, config.volumeShadowCubes);
        return volumes;
    }
    case Technique::MultiscalePrt: {
        auto prt = MultiscalePrt::create(config.multiscalePrt);
        prt->setLights(config.prtLights);
        return prt;
    }
    case Technique::None:
        break;
    }
    return std::make_unique<NullIndirectIllumination>();
}

bool needsSparsePoints(Technique technique) noexcept { return technique == Technique::LightSkin; }

std::optional<PrtPrepareStats> prtPrepareStatsOf(const IndirectIllumination& technique) {
    if (technique.technique() != Technique::MultiscalePrt) return std::nullopt;
    return static_cast<const MultiscalePrt&>(technique).lastPrepareStats();
}

} // namespace lightskin::gi
