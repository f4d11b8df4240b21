#pragma once
// The robust fit of RoomLightEstimator.h's model to one frame's samples. Internal to roomlight.

#include "SurfaceSamples.h"

#include <lightskin/roomlight/LightEstimate.h>
#include <lightskin/roomlight/RoomLightEstimator.h>

#include <array>
#include <optional>
#include <vector>

namespace lightskin::roomlight {

/// The free light of the model, about a reference point c: direction d (unit) and inverse distance u (1/m),
/// position c + d / u, or a directional light from d when u = 0.
struct FreeLight {
    glm::dvec3 direction{0.0, 0.0, 1.0};
    double inverseDistance = 0.0;
};

inline constexpr int kMaxColumns = 1 + kMaxEmitters + kShCount;

struct ModelFitResult {
    FreeLight light;
    glm::dvec3 lightIrradiance{0.0};                        ///< F per channel (>= 0)
    std::array<glm::dvec3, kMaxEmitters> emitterRadiance{}; ///< L_e per channel (>= 0)
    ShRgb ambientRadiance{};                                ///< R_k per channel
    std::array<glm::dvec3, kMaxSegments> albedo{};
    double residual = 0.0;
    int samplesFitted = 0;
};

class LightModelFit {
public:
    /// Fits the model; false when the system is singular or not finite. `warmStart` skips the global search
    /// of the free light. `emitters[0..emitterCount)` have their geometry set (radiance is fitted).
    bool run(const SurfaceSamples& samples, int segmentCount, const std::array<AreaEmitter, kMaxEmitters>& emitters,
             int emitterCount, const glm::dvec3& reference, const std::optional<FreeLight>& warmStart,
             const RoomLightOptions& options, ModelFitResult& result);

private:
    int columnCount() const noexcept { return 1 + emitterCount_ + kShCount; }
    /// fitIndex_ and searchIndex_ from the samples of segments [0, segments).
    void selectSamples(int segments);
    void buildEmitterPatches();
    void cacheFixedColumns();
    /// The shading (irradiance) the model gives sample `sample`, per channel.
    glm::dvec3 shadingAt(std::size_t sample, const FreeLight& light,
                         const std::array<glm::dvec3, kMaxColumns>& beta) const noexcept;
    void designRow(std::size_t sample, const FreeLight& light, double* row) const noexcept;
    double lightSearchCost(const FreeLight& light) const noexcept;
    FreeLight globalSearch() const noexcept;
    FreeLight patternSearch(FreeLight start, double angleStep, double inverseDistanceStep) const noexcept;
    bool solveLinear(const FreeLight& light, std::array<glm::dvec3, kMaxColumns>& beta) const noexcept;
    bool selectLights(const FreeLight& light, std::array<glm::dvec3, kMaxColumns>& beta);
    void updateWeights(const FreeLight& light, const std::array<glm::dvec3, kMaxColumns>& beta) noexcept;
    void updateAlbedo(const FreeLight& light, std::array<glm::dvec3, kMaxColumns>& beta) noexcept;
    double residual(const FreeLight& light, const std::array<glm::dvec3, kMaxColumns>& beta) const noexcept;

    const SurfaceSamples* samples_ = nullptr;
    const RoomLightOptions* options_ = nullptr;
    std::array<AreaEmitter, kMaxEmitters> emitters_{};
    int emitterCount_ = 0;
    int segmentCount_ = 0;
    glm::dvec3 reference_{0.0};
    std::array<glm::dvec3, kMaxSegments> albedo_{};
    std::vector<std::size_t> fitIndex_;    ///< samples with a segment
    std::vector<std::size_t> searchIndex_; ///< a subset of fitIndex_ for the free light's search
    std::array<std::vector<std::size_t>, 2> foldIndex_; ///< selectLights: the two halves of fitIndex_ by image block
    std::vector<int> sampleBlock_;                      ///< selectLights: image block per sample (indexed like samples)
    std::vector<double> blockErrorWith_, blockErrorWithout_; ///< selectLights: held-out squared error per block
    /// Below this many samples in a fold the cross-validation is not trusted: the light is dropped.
    static constexpr int kMinFoldSamples = 100;
    std::vector<double> weight_;           ///< robust weight per sample (indexed like samples)
    std::vector<double> scratch_;
    static constexpr std::size_t kFixedColumns = kMaxEmitters + kShCount;
    struct EmitterPatch {
        AreaEmitter disc;    ///< a small part of an emitter region (position, area; the region's normal)
        std::size_t emitter; ///< which region
    };
    std::vector<EmitterPatch> emitterPatches_;
    std::vector<double> fixedColumns_; ///< per sample: emitter and SH columns, kFixedColumns apart
    /// solveLinear fits these light columns (free light, emitters); a disabled one is held at 0.
    std::array<bool, 1 + kMaxEmitters> lightEnabled_{};
    ///< |relative residual| for the median
};

} // namespace lightskin::roomlight
