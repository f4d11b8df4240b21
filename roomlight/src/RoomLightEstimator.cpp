#include "LightModelFit.h"
#include "ModelTerms.h"
#include "SurfaceSamples.h"

#include <lightskin/core/Error.h>
#include <lightskin/roomlight/RoomLightEstimator.h>

#include <glm/geometric.hpp>
#include <glm/vector_relational.hpp>

#include <algorithm>
#include <cmath>
#include <utility>

namespace lightskin::roomlight {

const char* toString(EstimateState state) noexcept {
    switch (state) {
    case EstimateState::Fitted:
        return "fitted";
    case EstimateState::KeptLast:
        return "kept-last";
    case EstimateState::NeutralAmbient:
        return "neutral-ambient";
    }
    return "?";
}

const char* toString(FrameProblem problem) noexcept {
    switch (problem) {
    case FrameProblem::None:
        return "none";
    case FrameProblem::NoDepth:
        return "no-depth";
    case FrameProblem::Dark:
        return "dark";
    case FrameProblem::MostlyClipped:
        return "mostly-clipped";
    case FrameProblem::FitFailed:
        return "fit-failed";
    case FrameProblem::PoorFit:
        return "poor-fit";
    }
    return "?";
}

const char* toString(DominantSource source) noexcept {
    switch (source) {
    case DominantSource::None:
        return "none";
    case DominantSource::LocalLight:
        return "local-light";
    case DominantSource::Emitter:
        return "emitter";
    case DominantSource::ShLinearBand:
        return "sh-linear-band";
    }
    return "?";
}

namespace {

double luminance(const glm::dvec3& rgb) noexcept { return (rgb.x + rgb.y + rgb.z) / 3.0; }

/// Clipped samples with depth, as up to two regions (2-means when they spread over more than half a metre).
int findEmitters(const SurfaceSamples& samples, std::vector<std::size_t>& clippedIndex,
                 std::array<AreaEmitter, kMaxEmitters>& emitters) {
    constexpr std::size_t kMinSamples = 3;
    constexpr double kOneRegionRadius = 0.5; // metres
    clippedIndex.clear();
    glm::dvec3 centroid{0.0};
    for (std::size_t i = 0; i < samples.size(); ++i) {
        if (samples.clipped[i] == 0) continue;
        clippedIndex.push_back(i);
        centroid += samples.positionWorld[i];
    }
    if (clippedIndex.size() < kMinSamples) return 0;
    centroid /= static_cast<double>(clippedIndex.size());
    double spread = 0.0;
    std::size_t farthest = clippedIndex.front();
    for (const std::size_t i : clippedIndex) {
        const double d = glm::distance(samples.positionWorld[i], centroid);
        spread += d * d;
        if (d > glm::distance(samples.positionWorld[farthest], centroid)) farthest = i;
    }
    std::array<glm::dvec3, kMaxEmitters> centres{centroid, centroid};
    int regions = 1;
    if (std::sqrt(spread / static_cast<double>(clippedIndex.size())) > kOneRegionRadius) {
        regions = 2;
        centres[0] = samples.positionWorld[farthest];
        std::size_t other = farthest;
        for (const std::size_t i : clippedIndex)
            if (glm::distance(samples.positionWorld[i], centres[0]) >
                glm::distance(samples.positionWorld[other], centres[0]))
                other = i;
        centres[1] = samples.positionWorld[other];
    }
    std::array<glm::dvec3, kMaxEmitters> sum{}, normal{};
    std::array<double, kMaxEmitters> area{};
    std::array<int, kMaxEmitters> count{};
    for (int iteration = 0; iteration < (regions == 1 ? 1 : 6); ++iteration) {
        sum = {};
        normal = {};
        area = {};
        count = {};
        for (const std::size_t i : clippedIndex) {
            const glm::dvec3& p = samples.positionWorld[i];
            const std::size_t r = regions == 2 && glm::distance(p, centres[1]) < glm::distance(p, centres[0]) ? 1 : 0;
            sum[r] += p;
            normal[r] += samples.normalWorld[i];
            area[r] += samples.footprintSquareMetres[i];
            ++count[r];
        }
        for (std::size_t r = 0; r < static_cast<std::size_t>(regions); ++r)
            if (count[r] > 0) centres[r] = sum[r] / static_cast<double>(count[r]);
    }
    int found = 0;
    for (std::size_t r = 0; r < static_cast<std::size_t>(regions); ++r) {
        if (static_cast<std::size_t>(count[r]) < kMinSamples || !(glm::length(normal[r]) > 0.0)) continue;
        AreaEmitter& emitter = emitters[static_cast<std::size_t>(found++)];
        emitter = {};
        emitter.positionWorld = centres[r];
        emitter.normalWorld = glm::normalize(normal[r]);
        emitter.areaSquareMetres = area[r];
        emitter.sampleCount = count[r];
    }
    return found;
}

/// E0 of an emitter at the reference point (irradiance facing it), per channel, and the direction toward it.
glm::dvec3 emitterIrradianceAt(const AreaEmitter& emitter, const glm::dvec3& reference, glm::dvec3& towardEmitter) {
    const glm::dvec3 toReference = reference - emitter.positionWorld;
    const double squared = std::max(glm::dot(toReference, toReference), 1e-6);
    const double distance = std::sqrt(squared);
    towardEmitter = -toReference / distance;
    const double cosEmitter = std::max(glm::dot(emitter.normalWorld, toReference) / distance, 0.0);
    return emitter.radiance * (emitter.areaSquareMetres * cosEmitter / (squared + emitter.areaSquareMetres / kPi));
}

/// The irradiance SH at the reference point from the model's terms.
void assembleSh(LightEstimate& estimate) {
    estimate.sh = estimate.ambientSh;
    addDirectionalLight(estimate.sh, estimate.localLightDirectionWorld, estimate.localLightIrradiance);
    for (int e = 0; e < estimate.emitterCount; ++e) {
        glm::dvec3 toward{0.0};
        const glm::dvec3 e0 =
            emitterIrradianceAt(estimate.emitters[static_cast<std::size_t>(e)], estimate.referencePointWorld, toward);
        addDirectionalLight(estimate.sh, toward, e0);
    }
}

DominantLight makeDominant(const glm::dvec3& towardLight, const std::optional<glm::dvec3>& position,
                           const glm::dvec3& irradiance, DominantSource source) {
    DominantLight light;
    light.directionWorld = towardLight;
    light.positionWorld = position;
    light.intensity = luminance(irradiance);
    light.colour = light.intensity > 0.0 ? irradiance / light.intensity : glm::dvec3(1.0);
    light.source = source;
    return light;
}

/// The strongest of the free light and the emitters, if it stands out from the ambient; else the SH's own.
void chooseDominant(LightEstimate& estimate, double minDominantRatio) {
    const double ambientMean = luminance(estimate.sh[0]) * shBasis({0.0, 0.0, 1.0})[0]; // E averaged over the sphere
    const double threshold = minDominantRatio * std::max(ambientMean, 0.0);
    DominantLight best = makeDominant(estimate.localLightDirectionWorld, estimate.localLightPositionWorld,
                                      estimate.localLightIrradiance, DominantSource::LocalLight);
    for (int e = 0; e < estimate.emitterCount; ++e) {
        const AreaEmitter& emitter = estimate.emitters[static_cast<std::size_t>(e)];
        glm::dvec3 toward{0.0};
        const glm::dvec3 e0 = emitterIrradianceAt(emitter, estimate.referencePointWorld, toward);
        if (luminance(e0) > best.intensity)
            best = makeDominant(toward, emitter.positionWorld, e0, DominantSource::Emitter);
    }
    if (best.intensity > threshold && best.intensity > 0.0) {
        estimate.dominant = best;
        return;
    }
    const ShDominantLight fromSh = extractDominantLight(estimate.sh);
    if (luminance(fromSh.irradianceFacing) > threshold && luminance(fromSh.irradianceFacing) > 0.0) {
        estimate.dominant =
            makeDominant(fromSh.towardLight, std::nullopt, fromSh.irradianceFacing, DominantSource::ShLinearBand);
        return;
    }
    estimate.dominant = DominantLight{};
}

/// The fit's own estimate is physical: no channel of the mean irradiance (SH band 0), the free light or an emitter is
/// negative. The fit holds each of them non-negative, so this guards the assembly, not the data.
bool isPhysical(const LightEstimate& estimate) {
    bool physical = glm::all(glm::greaterThanEqual(estimate.sh[0], glm::dvec3(0.0))) &&
                    glm::all(glm::greaterThanEqual(estimate.ambientSh[0], glm::dvec3(0.0))) &&
                    glm::all(glm::greaterThanEqual(estimate.localLightIrradiance, glm::dvec3(0.0)));
    for (int e = 0; e < estimate.emitterCount; ++e)
        physical = physical && glm::all(glm::greaterThanEqual(estimate.emitters[static_cast<std::size_t>(e)].radiance,
                                                              glm::dvec3(0.0)));
    return physical;
}

bool allFinite(const LightEstimate& estimate) {
    double sum = estimate.residual + glm::dot(estimate.localLightIrradiance, glm::dvec3(1.0)) +
                 glm::dot(estimate.localLightDirectionWorld, glm::dvec3(1.0)) + estimate.dominant.intensity;
    for (const glm::dvec3& coefficient : estimate.sh) sum += coefficient.x + coefficient.y + coefficient.z;
    for (const AreaEmitter& emitter : estimate.emitters) sum += glm::dot(emitter.radiance, glm::dvec3(1.0));
    if (estimate.localLightPositionWorld) sum += glm::dot(*estimate.localLightPositionWorld, glm::dvec3(1.0));
    return std::isfinite(sum);
}

} // namespace

struct RoomLightEstimator::Impl {
    RoomLightOptions options;
    SurfaceSamples samples;
    std::vector<int> binCounts;
    std::vector<std::size_t> clippedIndex;
    std::vector<double> luminances;
    LightModelFit fit;
    ModelFitResult fitResult;
    LightEstimate current;
    bool hasFit = false; ///< current holds a fitted estimate (Fitted or KeptLast)
    double lastFitTime = std::nan("");

    FrameProblem checkFrame();
    void keepLast(FrameProblem problem);
    void buildRaw(LightEstimate& raw, const glm::dvec3& reference, int emitterCount,
                  const std::array<AreaEmitter, kMaxEmitters>& emitters) const;
    void filterInto(LightEstimate& raw, double elapsedSeconds) const;
};

FrameProblem RoomLightEstimator::Impl::checkFrame() {
    if (samples.size() < static_cast<std::size_t>(options.minSamples)) return FrameProblem::NoDepth;
    luminances.clear();
    std::size_t clippedCount = 0;
    for (std::size_t i = 0; i < samples.size(); ++i) {
        luminances.push_back(luminance(samples.radiance[i]));
        clippedCount += samples.clipped[i];
    }
    const auto middle = luminances.begin() + static_cast<std::ptrdiff_t>(luminances.size() / 2);
    std::nth_element(luminances.begin(), middle, luminances.end());
    if (*middle < options.darkLevel) return FrameProblem::Dark;
    if (static_cast<double>(clippedCount) > options.maxClippedFraction * static_cast<double>(samples.size()))
        return FrameProblem::MostlyClipped;
    return FrameProblem::None;
}

void RoomLightEstimator::Impl::keepLast(FrameProblem problem) {
    if (!hasFit) {
        current = LightEstimate{};
        current.state = EstimateState::NeutralAmbient;
        current.sh[0] = glm::dvec3(options.neutralIrradiance / shBasis({0.0, 0.0, 1.0})[0]);
        current.ambientSh = current.sh;
    } else {
        current.state = EstimateState::KeptLast;
    }
    current.problem = problem;
    current.exposureGain = glm::dvec3(1.0);
}

void RoomLightEstimator::Impl::buildRaw(LightEstimate& raw, const glm::dvec3& reference, int emitterCount,
                                        const std::array<AreaEmitter, kMaxEmitters>& emitters) const {
    raw = LightEstimate{};
    raw.state = EstimateState::Fitted;
    raw.referencePointWorld = reference;
    raw.localLightDirectionWorld = fitResult.light.direction;
    raw.localLightIrradiance = fitResult.lightIrradiance;
    if (fitResult.light.inverseDistance > 0.0)
        raw.localLightPositionWorld = reference + fitResult.light.direction / fitResult.light.inverseDistance;
    raw.emitterCount = 0; // the emitters the model selection kept
    for (std::size_t e = 0; e < static_cast<std::size_t>(emitterCount); ++e) {
        if (!(luminance(fitResult.emitterRadiance[e]) > 0.0)) continue;
        AreaEmitter& kept = raw.emitters[static_cast<std::size_t>(raw.emitterCount++)];
        kept = emitters[e];
        kept.radiance = fitResult.emitterRadiance[e];
    }
    raw.residual = fitResult.residual;
    raw.samplesFitted = fitResult.samplesFitted;
    for (int k = 0; k < kShCount; ++k)
        raw.ambientSh[static_cast<std::size_t>(k)] =
            irradianceConvolution(k) * fitResult.ambientRadiance[static_cast<std::size_t>(k)];
}

// Exposure and white balance scale every real pixel at once, so the previous estimate is first brought to this
// frame's scale (the per-channel ratio of the mean irradiance at the reference, band 0), then blended with
// weight alpha = 1 - exp(-dt / tau): only the light's shape and direction are smoothed.
void RoomLightEstimator::Impl::filterInto(LightEstimate& raw, double elapsedSeconds) const {
    const LightEstimate& previous = current;
    glm::dvec3 gain{1.0};
    for (int c = 0; c < 3; ++c)
        if (previous.sh[0][c] > 0.0 && raw.sh[0][c] > 0.0) gain[c] = raw.sh[0][c] / previous.sh[0][c];
    raw.exposureGain = gain;
    // The gain is measured on the whole irradiance at the reference (sh, before filtering), as the camera sees it.
    const double alpha = 1.0 - std::exp(-elapsedSeconds / options.timeConstantSeconds);
    const auto blend = [&](const glm::dvec3& before, const glm::dvec3& now) {
        return gain * before + alpha * (now - gain * before);
    };
    for (std::size_t k = 0; k < raw.ambientSh.size(); ++k)
        raw.ambientSh[k] = blend(previous.ambientSh[k], raw.ambientSh[k]);
    raw.localLightIrradiance = blend(previous.localLightIrradiance, raw.localLightIrradiance);
    const glm::dvec3 direction = glm::mix(previous.localLightDirectionWorld, raw.localLightDirectionWorld, alpha);
    if (glm::length(direction) > 1e-6) raw.localLightDirectionWorld = glm::normalize(direction);
    if (raw.localLightPositionWorld && previous.localLightPositionWorld)
        raw.localLightPositionWorld = glm::mix(*previous.localLightPositionWorld, *raw.localLightPositionWorld, alpha);
    if (raw.emitterCount == previous.emitterCount) {
        constexpr double kSameEmitterMetres = 0.3;
        for (std::size_t e = 0; e < static_cast<std::size_t>(raw.emitterCount); ++e)
            if (glm::distance(raw.emitters[e].positionWorld, previous.emitters[e].positionWorld) < kSameEmitterMetres)
                raw.emitters[e].radiance = blend(previous.emitters[e].radiance, raw.emitters[e].radiance);
    }
}

glm::dvec3 predictIrradiance(const LightEstimate& estimate, const glm::dvec3& positionWorld,
                             const glm::dvec3& normalWorld) noexcept {
    FreeLight light{estimate.localLightDirectionWorld, 0.0};
    if (estimate.localLightPositionWorld) {
        const glm::dvec3 toLight = *estimate.localLightPositionWorld - estimate.referencePointWorld;
        light = {glm::normalize(toLight), 1.0 / glm::length(toLight)};
    }
    glm::dvec3 irradiance =
        evaluateSh(estimate.ambientSh, normalWorld) +
        estimate.localLightIrradiance * freeLightTerm(light, estimate.referencePointWorld, positionWorld, normalWorld);
    for (int e = 0; e < estimate.emitterCount; ++e) {
        const AreaEmitter& emitter = estimate.emitters[static_cast<std::size_t>(e)];
        irradiance += emitter.radiance * emitterTerm(emitter, positionWorld, normalWorld);
    }
    return irradiance;
}

RoomLightEstimator::RoomLightEstimator(RoomLightOptions options)
    : impl_(std::make_unique<Impl>()) {
    LIGHTSKIN_ASSERT(options.stride >= 1 && options.normalRadius >= 1 && options.timeConstantSeconds > 0.0,
                     "stride and normalRadius must be >= 1, the time constant > 0");
    impl_->options = options;
    impl_->keepLast(FrameProblem::None);
}
RoomLightEstimator::~RoomLightEstimator() = default;
RoomLightEstimator::RoomLightEstimator(RoomLightEstimator&&) noexcept = default;
RoomLightEstimator& RoomLightEstimator::operator=(RoomLightEstimator&&) noexcept = default;

void RoomLightEstimator::reset() {
    impl_->hasFit = false;
    impl_->lastFitTime = std::nan("");
    impl_->keepLast(FrameProblem::None);
}

const LightEstimate& RoomLightEstimator::last() const noexcept { return impl_->current; }
const RoomLightOptions& RoomLightEstimator::options() const noexcept { return impl_->options; }

const LightEstimate& RoomLightEstimator::estimate(const RgbdFrame& frame, const Pose& world_T_camera,
                                                  std::optional<glm::dvec3> referencePointWorld) {
    Impl& m = *impl_;
    if (frame.hasDepth() && frame.registration != DepthRegistration::RegisteredToColour)
        throw Error("roomlight::RoomLightEstimator", frame.index, "depth is not registered to colour");
    extractSurfaceSamples(frame, world_T_camera, m.options, m.samples);
    if (const FrameProblem problem = m.checkFrame(); problem != FrameProblem::None) {
        m.keepLast(problem);
        return m.current;
    }
    const int segments = segmentSamples(m.samples, m.binCounts);
    std::array<AreaEmitter, kMaxEmitters> emitters{};
    const int emitterCount = findEmitters(m.samples, m.clippedIndex, emitters);
    glm::dvec3 reference{0.0};
    if (referencePointWorld) {
        reference = *referencePointWorld;
    } else {
        for (const glm::dvec3& p : m.samples.positionWorld) reference += p;
        reference /= static_cast<double>(m.samples.size());
    }
    std::optional<FreeLight> warmStart; // the last light, re-expressed about this frame's reference point
    if (m.hasFit && m.current.localLightPositionWorld) {
        const glm::dvec3 toLight = *m.current.localLightPositionWorld - reference;
        warmStart = FreeLight{glm::normalize(toLight), 1.0 / glm::length(toLight)};
    } else if (m.hasFit) {
        warmStart = FreeLight{m.current.localLightDirectionWorld, 0.0};
    }
    if (!m.fit.run(m.samples, segments, emitters, emitterCount, reference, warmStart, m.options, m.fitResult)) {
        m.keepLast(FrameProblem::FitFailed);
        return m.current;
    }
    LightEstimate raw;
    m.buildRaw(raw, reference, emitterCount, emitters);
    if (!(raw.residual <= m.options.maxResidual)) {
        m.keepLast(FrameProblem::PoorFit);
        return m.current;
    }
    const double time = frame.colourTimestampSeconds;
    double elapsed = time - m.lastFitTime;
    if (!std::isfinite(elapsed) || elapsed <= 0.0 || elapsed > 1.0) elapsed = m.options.nominalFrameSeconds;
    assembleSh(raw); // the unfiltered sh: filterInto measures the camera's gain on it
    if (!isPhysical(raw)) {
        m.keepLast(FrameProblem::PoorFit);
        return m.current;
    }
    if (m.hasFit) {
        m.filterInto(raw, elapsed);
        assembleSh(raw);
    }
    chooseDominant(raw, m.options.minDominantRatio);
    if (!allFinite(raw)) {
        m.keepLast(FrameProblem::FitFailed);
        return m.current;
    }
    m.current = raw;
    m.hasFit = true;
    m.lastFitTime = time;
    return m.current;
}

} // namespace lightskin::roomlight
