#include <lightskin/core/Error.h>
#include <lightskin/core/TriangleMesh.h>
#include <lightskin/mr/FrameBudget.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace lightskin::mr {

std::string describe(const QualitySettings& s) {
    std::string text(gi::toString(s.technique));
    if (s.technique == Technique::LightSkin) text += " sparse=" + std::to_string(s.sparsePoints);
    text += " stride=" + std::to_string(s.valStride);
    if (s.glossy) text += " +glossy";
    if (s.occlusion) text += " +occlusion";
    return text;
}

render::GiSettings applyTo(const QualitySettings& s, render::GiSettings gi) {
    gi.technique = s.technique;
    if (s.technique == Technique::LightSkin) gi.sparsePoints = s.sparsePoints;
    gi.valStride = s.valStride;
    gi.glossy = s.glossy;
    gi.occlusion = s.occlusion;
    return gi;
}

namespace {

/// Every vertex behind or on every face plane (tolerance relative to the mesh size).
bool isConvex(const TriangleMesh& mesh) {
    const std::size_t pairs = mesh.triangleCount() * mesh.vertexCount();
    if (pairs == 0) return true;
    if (pairs > 20'000'000) return false; // too big to check once at start-up: assume it can occlude
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (const glm::vec3& p : mesh.positions) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    const float tolerance = 1e-5f * glm::length(hi - lo);
    for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
        const glm::vec3 a = mesh.positions[mesh.indices[3 * t]], b = mesh.positions[mesh.indices[3 * t + 1]],
                        c = mesh.positions[mesh.indices[3 * t + 2]];
        const glm::vec3 n = glm::cross(b - a, c - a);
        const float length = glm::length(n);
        if (!(length > 0.0f)) continue; // degenerate face: no plane
        const glm::vec3 unit = n / length;
        for (const glm::vec3& p : mesh.positions)
            if (glm::dot(unit, p - a) > tolerance) return false;
    }
    return true;
}

} // namespace

SceneNeeds sceneNeeds(std::span<const gi::MeshInstance> instances) {
    SceneNeeds needs;
    needs.objects = std::max<int>(1, int(instances.size()));
    needs.glossy = false;
    for (const gi::MeshInstance& i : instances)
        needs.glossy = needs.glossy || std::max({i.material.specularAlbedo.x, i.material.specularAlbedo.y,
                                                 i.material.specularAlbedo.z}) > 0.0f;
    needs.occlusion = instances.size() > 1 || (instances.size() == 1 && !isConvex(*instances[0].mesh));
    return needs;
}

FrameBudget::FrameBudget(const BudgetOptions& options, const SceneNeeds& needs, const QualitySettings& initial)
    : options_(options)
    , needs_(needs) {
    if (!(options.budgetMs > 0.0) || !std::isfinite(options.budgetMs))
        throw Error("frame budget", std::nullopt,
                    "the budget must be a positive number of milliseconds, got " + std::to_string(options.budgetMs));
    if (options.sparsePointChoices.empty() || options.valStrideChoices.empty())
        throw Error("frame budget", std::nullopt, "the sparse-point and VAL-stride choices must not be empty");
    for (int s : options.sparsePointChoices)
        if (s < 16 || s > 65536)
            throw Error("frame budget", std::nullopt,
                        "sparse points per object must be in [16, 65536], got " + std::to_string(s));
    for (int s : options.valStrideChoices)
        if (s < 1 || s > 64)
            throw Error("frame budget", std::nullopt, "VAL strides must be in [1, 64], got " + std::to_string(s));
    // Channels the scene needs may be dropped (when allowed); channels it cannot use never run.
    std::vector<bool> glossyChoices{needs.glossy}, occlusionChoices{needs.occlusion};
    if (options.allowDroppingChannels && needs.glossy) glossyChoices.push_back(false);
    if (options.allowDroppingChannels && needs.occlusion) occlusionChoices.push_back(false);
    for (int stride : options.valStrideChoices)
        for (bool glossy : glossyChoices) {
            for (int sparse : options.sparsePointChoices)
                for (bool occlusion : occlusionChoices)
                    candidates_.push_back({Technique::LightSkin, sparse, stride, glossy, occlusion});
            if (options.allowBruteForce)
                candidates_.push_back({Technique::BruteForce, initial.sparsePoints, stride, glossy, false});
        }
    msPerUnit_.assign(candidates_.size(), -1.0);
    measuredError_.assign(candidates_.size(), -1.0);
    QualitySettings start = initial;
    start.glossy = start.glossy && needs.glossy;
    start.occlusion = start.occlusion && needs.occlusion && start.technique == Technique::LightSkin;
    current_ = indexOf(start);
    if (current_ == candidates_.size()) current_ = 0; // the scene's settings are not a candidate: start anywhere
}

std::size_t FrameBudget::indexOf(const QualitySettings& settings) const {
    for (std::size_t i = 0; i < candidates_.size(); ++i) {
        const QualitySettings& c = candidates_[i];
        const bool same = c.technique == settings.technique && c.valStride == settings.valStride &&
                          c.glossy == settings.glossy && c.occlusion == settings.occlusion &&
                          (c.technique == Technique::BruteForce || c.sparsePoints == settings.sparsePoints);
        if (same) return i;
    }
    return candidates_.size();
}

void FrameBudget::setBudgetMs(double budgetMs) {
    if (!(budgetMs > 0.0) || !std::isfinite(budgetMs))
        throw Error("frame budget", std::nullopt,
                    "the budget must be a positive number of milliseconds, got " + std::to_string(budgetMs));
    options_.budgetMs = budgetMs;
}

double FrameBudget::modelUnits(const QualitySettings& c, const FrameStats& stats) const {
    const double s0 = double(std::max(1, stats.valStride)), s = double(c.valStride);
    const double vals = stats.vals * (s0 * s0) / (s * s);
    const double pixels = stats.coveredPixels;
    const CostPrior& k = options_.cost;
    if (c.technique == Technique::BruteForce)
        return pixels * vals * (1.0 + (c.glossy ? k.bruteForceGlossyFactor : 0.0));
    const double points = double(c.sparsePoints) * needs_.objects;
    return points * vals * (1.0 + (c.glossy ? k.lightSkinGlossyFactor : 0.0)) +
           (c.occlusion ? k.occlusionPerPointPair * points * points : 0.0) + k.lightSkinPerPixel * pixels;
}

double FrameBudget::predictMs(const QualitySettings& c, const FrameStats& stats) const {
    const std::size_t i = indexOf(c);
    const int t = c.technique == Technique::LightSkin ? 0 : 1;
    const double prior = t == 0 ? options_.cost.lightSkinMsPerInteraction : options_.cost.bruteForceMsPerInteraction;
    const double perUnit = i < candidates_.size() && msPerUnit_[i] >= 0.0 ? msPerUnit_[i] : prior * techniqueRatio_[t];
    return otherMs_ + perUnit * modelUnits(c, stats);
}

double FrameBudget::expectedError(const QualitySettings& c) const {
    const std::size_t i = indexOf(c);
    if (i < candidates_.size() && measuredError_[i] >= 0.0) return measuredError_[i];
    const ErrorPrior& e = options_.error;
    double error = e.perStrideStep * double(c.valStride - 1);
    if (c.technique == Technique::LightSkin)
        error += e.interpolationAt1024 * std::pow(1024.0 / double(c.sparsePoints), e.interpolationExponent);
    if (needs_.occlusion && !(c.technique == Technique::LightSkin && c.occlusion)) error += e.missingVisibility;
    if (needs_.glossy && !c.glossy) error += e.droppedGlossy;
    return error;
}

void FrameBudget::observeError(const QualitySettings& settings, double relativeMse) {
    const std::size_t i = indexOf(settings);
    if (i < candidates_.size() && std::isfinite(relativeMse) && relativeMse >= 0.0) measuredError_[i] = relativeMse;
}

void FrameBudget::observe(const QualitySettings& ran, const FrameStats& stats, const StageCosts& costs) {
    if (!std::isfinite(costs.giMs) || !std::isfinite(costs.otherMs) || costs.giMs < 0.0 || costs.otherMs < 0.0) return;
    otherMs_ = costs.otherMs;
    const double units = modelUnits(ran, stats);
    const std::size_t i = indexOf(ran);
    if (!(units > 0.0) || i == candidates_.size()) return; // nothing to scale (no VALs, nothing covered)
    const double perUnit = costs.giMs / units;
    msPerUnit_[i] = msPerUnit_[i] < 0.0 ? perUnit : msPerUnit_[i] + options_.smoothing * (perUnit - msPerUnit_[i]);
    const int t = ran.technique == Technique::LightSkin ? 0 : 1;
    techniqueRatio_[t] =
        msPerUnit_[i] / (t == 0 ? options_.cost.lightSkinMsPerInteraction : options_.cost.bruteForceMsPerInteraction);
}

const QualitySettings& FrameBudget::choose(const FrameStats& stats) {
    const double budget = options_.budgetMs;
    std::size_t best = candidates_.size(), cheapest = 0;
    double bestError = std::numeric_limits<double>::infinity(), bestMs = 0.0,
           cheapestMs = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < candidates_.size(); ++i) {
        const double ms = predictMs(candidates_[i], stats);
        if (ms < cheapestMs) {
            cheapestMs = ms;
            cheapest = i;
        }
        const double limit = i == current_ ? budget : options_.switchMargin * budget;
        if (ms > limit) continue;
        const double error = expectedError(candidates_[i]);
        if (error < bestError || (error == bestError && ms < bestMs)) {
            best = i;
            bestError = error;
            bestMs = ms;
        }
    }
    current_ = best < candidates_.size() ? best : cheapest;
    return candidates_[current_];
}

} // namespace lightskin::mr
