#pragma once
// A frame-time budget ("model only what the scene requires"): picks the GI settings (technique,
// sparse points per object, VAL stride, glossy and occlusion channels) that meet a budget in
// milliseconds with the least expected error, from a cost model that online timing corrects.
// Deterministic: no clock inside (the caller measures and observes). The cost and error models,
// the online update and the hysteresis: docs/PLUGIN.md, "Frame-time budget".

#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gi/common/Technique.h>
#include <lightskin/render/Scene.h>

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace lightskin::mr {

/// The budget chooses between LightSkin and the brute force (the techniques with its knobs).
using Technique = gi::Technique;

/// One configuration the budget can choose.
struct QualitySettings {
    Technique technique = Technique::LightSkin;
    int sparsePoints = 1024; ///< per object (render::GiSettings::sparsePoints); unused by the brute force
    int valStride = 4;       ///< one VAL per stride x stride depth pixels
    bool glossy = true;
    bool occlusion = true; ///< LightSkin only (the brute force has no occlusion term)
    bool operator==(const QualitySettings&) const = default;
};
/// "lightskin sparse=1024 stride=4 +glossy +occlusion"
std::string describe(const QualitySettings& settings);
/// The scene's GI settings with `settings` applied.
render::GiSettings applyTo(const QualitySettings& settings, render::GiSettings gi);

/// What can change the image at all (fixed per scene).
struct SceneNeeds {
    bool glossy = true;    ///< some material has a specular albedo > 0
    bool occlusion = true; ///< more than one object, or a non-convex one
    int objects = 1;       ///< sparse points are per object
};
/// From the renderer's instances: glossy = any specular albedo > 0; occlusion = more than one
/// instance or a mesh that is not convex (a vertex in front of a face plane by more than 1e-5 of
/// the mesh size; meshes with more than 2e7 vertex-face pairs count as non-convex unchecked).
SceneNeeds sceneNeeds(std::span<const gi::MeshInstance> instances);

/// Per-frame counts the costs scale with.
struct FrameStats {
    double vals = 0.0;          ///< VALs made this frame
    int valStride = 4;          ///< ... at this stride
    double coveredPixels = 0.0; ///< pixels the virtual content covered
};
/// Measured costs of one frame, ms.
struct StageCosts {
    double giMs = 0.0;    ///< G-buffer + GI technique
    double otherMs = 0.0; ///< everything else in the frame
};

struct CostPrior {
    double lightSkinMsPerInteraction = 1.0e-5; ///< gather: 2048 points x 18341 VALs in 377 ms
    double lightSkinGlossyFactor = 0.5;
    /// In interactions: 48 ms for 2048^2 pairs (1.1) .. 1657 ms for 8192^2 (2.5) at 1e-5 ms; the middle.
    double occlusionPerPointPair = 1.8;
    double lightSkinPerPixel = 2.6;             ///< in interactions: shading 54 ms for 2.07 Mpx at 1e-5 ms
    double bruteForceMsPerInteraction = 8.2e-6; ///< 49.8 s for 332512 px x 18341 VALs (+ glossy)
    double bruteForceGlossyFactor = 0.5;
};

struct ErrorPrior {
    double interpolationAt1024 = 2.0e-4; ///< rel. MSE vs brute, diffuse, 1024 points per model (--quick)
    double interpolationExponent = 0.92; ///< 1.9e-3 at 64 -> 2.0e-4 at 1024: S^-0.81..-1.0
    double perStrideStep = 2.0e-4;       ///< 1.06e-2 (stride 4) -> 1.14e-2 (stride 8) vs brute on one map
    double missingVisibility = 4.0e-3;   ///< brute force 8.57e-3 vs LightSkin + occlusion 4.60e-3 (Cycles)
    double droppedGlossy = 5.0e-3;       ///< not measured: a guess that keeps glossy on when affordable
};

struct BudgetOptions {
    double budgetMs = 0.0; ///< > 0
    std::vector<int> sparsePointChoices{256, 1024, 4096};
    std::vector<int> valStrideChoices{2, 4, 8};
    bool allowBruteForce = true;
    /// Also consider turning off a channel the scene needs (glossy, occlusion) to meet the budget.
    bool allowDroppingChannels = true;
    double smoothing = 0.3;    ///< weight of a new measurement of a configuration already measured
    double switchMargin = 0.9; ///< another configuration must fit in switchMargin * budget
    CostPrior cost;
    ErrorPrior error;
};

class FrameBudget {
public:
    /// Throws lightskin::Error when the budget is not > 0 or a choice list is empty or invalid.
    FrameBudget(const BudgetOptions& options, const SceneNeeds& needs, const QualitySettings& initial);

    /// The configuration for the next frame (the last one until observe() tells more).
    const QualitySettings& choose(const FrameStats& stats);
    /// Records the measured costs of a frame rendered with `ran` (counts in `stats`).
    void observe(const QualitySettings& ran, const FrameStats& stats, const StageCosts& costs);
    /// A measured error of a configuration (replaces its prior).
    void observeError(const QualitySettings& settings, double relativeMse);

    double predictMs(const QualitySettings& settings, const FrameStats& stats) const;
    double expectedError(const QualitySettings& settings) const;
    /// Model units of the GI stage (interactions), before the ms factor.
    double modelUnits(const QualitySettings& settings, const FrameStats& stats) const;

    std::span<const QualitySettings> candidates() const noexcept { return candidates_; }
    const QualitySettings& current() const noexcept { return candidates_[current_]; }
    const SceneNeeds& needs() const noexcept { return needs_; }
    double budgetMs() const noexcept { return options_.budgetMs; }
    void setBudgetMs(double budgetMs);

private:
    std::size_t indexOf(const QualitySettings& settings) const;
    BudgetOptions options_;
    SceneNeeds needs_;
    std::vector<QualitySettings> candidates_;
    std::vector<double> msPerUnit_;         ///< measured, per candidate; < 0 = not measured
    std::vector<double> measuredError_;     ///< < 0 = prior
    double techniqueRatio_[2] = {1.0, 1.0}; ///< last measured / prior, per technique
    double otherMs_ = 0.0;
    std::size_t current_ = 0;
};

} // namespace lightskin::mr
