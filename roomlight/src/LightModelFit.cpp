#include "LightModelFit.h"

#include "ModelTerms.h"

#include <glm/geometric.hpp>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>

namespace lightskin::roomlight {
namespace {

using NormalMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxColumns, kMaxColumns>;
using RightHandSide = Eigen::Matrix<double, Eigen::Dynamic, 3, 0, kMaxColumns, 3>;
using SearchMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 2 + kMaxEmitters, 2 + kMaxEmitters>;
using SearchVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 2 + kMaxEmitters, 1>;

constexpr double kTukeyConstant = 4.685;    // 95 % efficiency under Gaussian noise
constexpr double kMadToSigma = 1.4826;      // MAD of a Gaussian = 0.6745 sigma
constexpr double kMinRelativeScale = 0.02;  // 8-bit quantisation and normal noise: a few % of a pixel value
constexpr double kMaxInverseDistance = 5.0; // lights closer than 0.2 m to the reference are not searched
constexpr std::size_t kSearchSamples = 1500;

double luminance(const glm::dvec3& rgb) noexcept { return (rgb.x + rgb.y + rgb.z) / 3.0; }

glm::dvec3 rotateToward(const glm::dvec3& direction, const glm::dvec3& tangent, double angle) noexcept {
    return glm::normalize(direction * std::cos(angle) + tangent * std::sin(angle));
}

std::array<glm::dvec3, 2> tangentsOf(const glm::dvec3& direction) noexcept {
    const glm::dvec3 helper = std::abs(direction.z) < 0.9 ? glm::dvec3(0.0, 0.0, 1.0) : glm::dvec3(1.0, 0.0, 0.0);
    const glm::dvec3 first = glm::normalize(glm::cross(direction, helper));
    return {first, glm::cross(direction, first)};
}

// The ambient's mean radiance (band 0) may not be negative in any channel: a negative ambient is no light, and when
// the samples' normals barely vary (one wall) the free light's shading is nearly the constant band 0 itself, so the
// unconstrained pair cancels (a light of E0 500 against an ambient of -370 on the 64 x 48 test wall). A channel
// whose band 0 comes out negative is refitted with it held at 0 (the active-set step of non-negative least squares
// for the one constraint that is violated).
bool holdAmbientMeanNonNegative(const NormalMatrix& normalMatrix, const RightHandSide& rhs, int bandZero,
                                RightHandSide& solution) {
    if ((solution.row(bandZero).array() >= 0.0).all()) return true;
    NormalMatrix held = normalMatrix;
    held.row(bandZero).setZero();
    held.col(bandZero).setZero();
    held(bandZero, bandZero) = 1.0;
    RightHandSide heldRhs = rhs;
    heldRhs.row(bandZero).setZero();
    Eigen::LDLT<NormalMatrix> solver(held);
    if (solver.info() != Eigen::Success) return false;
    const RightHandSide heldSolution = solver.solve(heldRhs);
    if (!heldSolution.allFinite()) return false;
    for (int channel = 0; channel < 3; ++channel)
        if (solution(bandZero, channel) < 0.0) solution.col(channel) = heldSolution.col(channel);
    return true;
}

} // namespace

void LightModelFit::designRow(std::size_t i, const FreeLight& light, double* row) const noexcept {
    row[0] = freeLightTerm(light, reference_, samples_->positionWorld[i], samples_->normalWorld[i]);
    const double* fixed = &fixedColumns_[i * kFixedColumns];
    std::copy(fixed, fixed + emitterCount_ + kShCount, row + 1);
}

// The emitter and SH columns do not change during a frame's fit: computed once per sample.
// An emitter's light on the samples as the sum over its clipped samples (at most kMaxPatchesPerEmitter, each
// standing for its share of the region's area), each a small disc with the region's normal: the square light of a
// lamp or a window subtends a wide angle from the walls next to it, where one disc at the centroid is wrong.
void LightModelFit::buildEmitterPatches() {
    constexpr std::size_t kMaxPatchesPerEmitter = 32;
    emitterPatches_.clear();
    std::array<std::size_t, kMaxEmitters> clippedOf{};
    const auto nearestEmitter = [&](const glm::dvec3& position) {
        std::size_t nearest = 0;
        for (std::size_t e = 1; e < static_cast<std::size_t>(emitterCount_); ++e)
            if (glm::distance(position, emitters_[e].positionWorld) <
                glm::distance(position, emitters_[nearest].positionWorld))
                nearest = e;
        return nearest;
    };
    for (std::size_t i = 0; i < samples_->size(); ++i)
        if (samples_->clipped[i] != 0) ++clippedOf[nearestEmitter(samples_->positionWorld[i])];
    std::array<std::size_t, kMaxEmitters> seen{};
    for (std::size_t i = 0; i < samples_->size(); ++i) {
        if (samples_->clipped[i] == 0) continue;
        const std::size_t e = nearestEmitter(samples_->positionWorld[i]);
        const std::size_t every = (clippedOf[e] + kMaxPatchesPerEmitter - 1) / kMaxPatchesPerEmitter;
        if (seen[e]++ % every != 0) continue;
        AreaEmitter disc = emitters_[e];
        disc.positionWorld = samples_->positionWorld[i];
        disc.areaSquareMetres = 0.0;
        emitterPatches_.push_back({disc, e});
    }
    // Patch areas: the region's area shared evenly (the footprints of the skipped samples are not known per patch).
    std::array<std::size_t, kMaxEmitters> patches{};
    for (const EmitterPatch& patch : emitterPatches_) ++patches[patch.emitter];
    for (EmitterPatch& patch : emitterPatches_)
        patch.disc.areaSquareMetres =
            emitters_[patch.emitter].areaSquareMetres / static_cast<double>(patches[patch.emitter]);
}

void LightModelFit::cacheFixedColumns() {
    buildEmitterPatches();
    fixedColumns_.resize(samples_->size() * kFixedColumns);
    for (std::size_t i = 0; i < samples_->size(); ++i) {
        if (samples_->segment[i] < 0) continue;
        double* fixed = &fixedColumns_[i * kFixedColumns];
        const glm::dvec3& position = samples_->positionWorld[i];
        const glm::dvec3& normal = samples_->normalWorld[i];
        for (int e = 0; e < emitterCount_; ++e) fixed[e] = 0.0;
        for (const EmitterPatch& patch : emitterPatches_)
            fixed[patch.emitter] += emitterTerm(patch.disc, position, normal);
        const ShBasis y = shBasis(normal);
        for (int k = 0; k < kShCount; ++k)
            fixed[emitterCount_ + k] = irradianceConvolution(k) * y[static_cast<std::size_t>(k)];
    }
}

// Variable projection: the weighted residual of the luminance fit with the light's (d, u) fixed, on the search
// subset. Every segment gets its own light and ambient scale (columns light, emitters, constant), so the cost does
// not depend on the albedos: only the light's geometry is shared, and each segment's shading pattern must agree
// with it. (A joint fit from guessed albedos trades the albedos against the light's direction.)
double LightModelFit::lightSearchCost(const FreeLight& light) const noexcept {
    // The free light is another light than the emitters: it may not sit on one (it would split its light).
    constexpr double kMinDistanceToEmitter = 0.5; // metres
    if (light.inverseDistance > 0.0) {
        const glm::dvec3 position = reference_ + light.direction / light.inverseDistance;
        for (int e = 0; e < emitterCount_; ++e)
            if (glm::distance(position, emitters_[static_cast<std::size_t>(e)].positionWorld) < kMinDistanceToEmitter)
                return std::numeric_limits<double>::max();
    }
    const int columns = 2 + emitterCount_;
    std::array<SearchMatrix, kMaxSegments> normalMatrix;
    std::array<SearchVector, kMaxSegments> rhs;
    std::array<double, kMaxSegments> targetSquares{};
    for (std::size_t s = 0; s < static_cast<std::size_t>(segmentCount_); ++s) {
        normalMatrix[s] = SearchMatrix::Zero(columns, columns);
        rhs[s] = SearchVector::Zero(columns);
    }
    std::array<double, kMaxColumns> row{};
    for (const std::size_t i : searchIndex_) {
        const double w = weight_[i];
        if (w <= 0.0) continue;
        // The search's columns only: the free light, the emitters (cached), a constant.
        row[0] = freeLightTerm(light, reference_, samples_->positionWorld[i], samples_->normalWorld[i]);
        const double* fixed = &fixedColumns_[i * kFixedColumns];
        for (int e = 0; e < emitterCount_; ++e) row[static_cast<std::size_t>(1 + e)] = fixed[e];
        row[static_cast<std::size_t>(1 + emitterCount_)] = 1.0;
        const auto s = static_cast<std::size_t>(samples_->segment[i]);
        const double target = luminance(samples_->radiance[i]);
        for (int r = 0; r < columns; ++r) {
            const double wr = w * row[static_cast<std::size_t>(r)];
            for (int c = 0; c <= r; ++c) normalMatrix[s](r, c) += wr * row[static_cast<std::size_t>(c)];
            rhs[s](r) += wr * target;
        }
        targetSquares[s] += w * target * target;
    }
    double cost = 0.0;
    for (std::size_t s = 0; s < static_cast<std::size_t>(segmentCount_); ++s) {
        SearchMatrix& a = normalMatrix[s];
        a.triangularView<Eigen::StrictlyUpper>() = a.transpose();
        a.diagonal().array() += 1e-9 * (a.diagonal().maxCoeff() + 1e-30); // segments that see no light
        SearchVector beta = Eigen::LDLT<SearchMatrix>(a).solve(rhs[s]);
        if (beta(0) < 0.0) { // a light may not be negative: the model without it
            a.row(0).setZero();
            a.col(0).setZero();
            a(0, 0) = 1.0;
            rhs[s](0) = 0.0;
            beta = Eigen::LDLT<SearchMatrix>(a).solve(rhs[s]);
        }
        cost += targetSquares[s] - rhs[s].dot(beta);
    }
    return std::isfinite(cost) ? cost : std::numeric_limits<double>::max();
}

// 128 directions (a Fibonacci sphere) times four inverse distances: 0 (directional), 0.3, 0.7, 1.5 per metre.
FreeLight LightModelFit::globalSearch() const noexcept {
    constexpr int kDirections = 128;
    constexpr std::array<double, 4> kInverseDistances{0.0, 0.3, 0.7, 1.5};
    const double goldenAngle = kPi * (3.0 - std::sqrt(5.0));
    FreeLight best;
    double bestCost = std::numeric_limits<double>::max();
    for (int i = 0; i < kDirections; ++i) {
        const double z = 1.0 - (2.0 * i + 1.0) / kDirections;
        const double ring = std::sqrt(1.0 - z * z);
        const double phi = goldenAngle * i;
        const glm::dvec3 direction{ring * std::cos(phi), ring * std::sin(phi), z};
        for (const double u : kInverseDistances) {
            const FreeLight candidate{direction, u};
            const double cost = lightSearchCost(candidate);
            if (cost < bestCost) {
                bestCost = cost;
                best = candidate;
            }
        }
    }
    return best;
}

// Compass search on (d, u): try +-step along two tangents and along u, keep any improvement, halve the steps
// when none helps, stop below 0.1 degree.
FreeLight LightModelFit::patternSearch(FreeLight current, double angleStep, double inverseDistanceStep) const noexcept {
    double currentCost = lightSearchCost(current);
    constexpr double kMinAngleStep = 0.1 * kPi / 180.0;
    for (int evaluations = 0; angleStep > kMinAngleStep && evaluations < 120;) {
        bool improved = false;
        const auto tangents = tangentsOf(current.direction);
        std::array<FreeLight, 6> moves{};
        for (int s = 0; s < 2; ++s) {
            const double sign = s == 0 ? 1.0 : -1.0;
            moves[static_cast<std::size_t>(s)] = {rotateToward(current.direction, tangents[0], sign * angleStep),
                                                  current.inverseDistance};
            moves[static_cast<std::size_t>(2 + s)] = {rotateToward(current.direction, tangents[1], sign * angleStep),
                                                      current.inverseDistance};
            moves[static_cast<std::size_t>(4 + s)] = {
                current.direction,
                std::clamp(current.inverseDistance + sign * inverseDistanceStep, 0.0, kMaxInverseDistance)};
        }
        for (const FreeLight& move : moves) {
            const double cost = lightSearchCost(move);
            ++evaluations;
            if (cost < currentCost) {
                currentCost = cost;
                current = move;
                improved = true;
            }
        }
        if (!improved) {
            angleStep *= 0.5;
            inverseDistanceStep *= 0.5;
        }
    }
    return current;
}

bool LightModelFit::solveLinear(const FreeLight& light, std::array<glm::dvec3, kMaxColumns>& beta) const noexcept {
    const int columns = columnCount();
    NormalMatrix normalMatrix = NormalMatrix::Zero(columns, columns);
    RightHandSide rhs = RightHandSide::Zero(columns, 3);
    std::array<std::array<double, kMaxColumns>, kMaxColumns> lower{};
    std::array<glm::dvec3, kMaxColumns> moments{};
    std::array<double, kMaxColumns> row{};
    for (const std::size_t i : fitIndex_) {
        const glm::dvec3& albedo = albedo_[static_cast<std::size_t>(samples_->segment[i])];
        const double meanAlbedo = luminance(albedo);
        const double w = weight_[i] * meanAlbedo * meanAlbedo;
        if (w <= 0.0) continue;
        designRow(i, light, row.data());
        const glm::dvec3 target = kPi * samples_->radiance[i] / albedo;
        // Plain loops over the lower triangle: for <= 12 columns they beat Eigen's dynamic-size rank update.
        for (int r = 0; r < columns; ++r) {
            const double wr = w * row[static_cast<std::size_t>(r)];
            for (int c = 0; c <= r; ++c)
                lower[static_cast<std::size_t>(r)][static_cast<std::size_t>(c)] +=
                    wr * row[static_cast<std::size_t>(c)];
            moments[static_cast<std::size_t>(r)] += wr * target;
        }
    }
    for (int r = 0; r < columns; ++r) {
        for (int c = 0; c <= r; ++c)
            normalMatrix(r, c) = normalMatrix(c, r) = lower[static_cast<std::size_t>(r)][static_cast<std::size_t>(c)];
        const glm::dvec3& moment = moments[static_cast<std::size_t>(r)];
        rhs(r, 0) = moment.x;
        rhs(r, 1) = moment.y;
        rhs(r, 2) = moment.z;
    }
    const int firstSh = 1 + emitterCount_;
    const double ridge = options_->ambientRidge * normalMatrix(firstSh, firstSh);
    // Bands 1 and 2 are held toward 0: the normals one frame shows rarely constrain them (half the sphere is never
    // seen), and unheld they would trade with the free light.
    for (int k = firstSh + 1; k < columns; ++k) normalMatrix(k, k) += ridge;
    for (int c = 0; c < firstSh; ++c) {
        if (lightEnabled_[static_cast<std::size_t>(c)]) continue;
        normalMatrix.row(c).setZero();
        normalMatrix.col(c).setZero();
        normalMatrix(c, c) = 1.0;
        rhs.row(c).setZero();
    }
    // Lights may not be negative: a light column whose luminance comes out negative is removed and the rest refitted.
    for (int attempt = 0; attempt <= firstSh; ++attempt) {
        Eigen::LDLT<NormalMatrix> solver(normalMatrix);
        if (solver.info() != Eigen::Success) return false;
        RightHandSide solution = solver.solve(rhs);
        if (!solution.allFinite()) return false;
        int negative = -1;
        for (int c = 0; c < firstSh && negative < 0; ++c)
            if (solution.row(c).sum() < 0.0) negative = c;
        if (negative < 0) {
            if (!holdAmbientMeanNonNegative(normalMatrix, rhs, firstSh, solution)) return false;
            for (int c = 0; c < columns; ++c) {
                beta[static_cast<std::size_t>(c)] = {solution(c, 0), solution(c, 1), solution(c, 2)};
                if (c < firstSh) beta[static_cast<std::size_t>(c)] = glm::max(beta[static_cast<std::size_t>(c)], 0.0);
            }
            return true;
        }
        normalMatrix.row(negative).setZero();
        normalMatrix.col(negative).setZero();
        normalMatrix(negative, negative) = 1.0;
        rhs.row(negative).setZero();
    }
    return false;
}

glm::dvec3 LightModelFit::shadingAt(std::size_t sample, const FreeLight& light,
                                    const std::array<glm::dvec3, kMaxColumns>& beta) const noexcept {
    std::array<double, kMaxColumns> row{};
    designRow(sample, light, row.data());
    glm::dvec3 shading{0.0};
    for (int c = 0; c < columnCount(); ++c)
        shading += row[static_cast<std::size_t>(c)] * beta[static_cast<std::size_t>(c)];
    return shading;
}

void LightModelFit::updateWeights(const FreeLight& light, const std::array<glm::dvec3, kMaxColumns>& beta) noexcept {
    scratch_.clear();
    for (const std::size_t i : fitIndex_) {
        const glm::dvec3 shading = shadingAt(i, light, beta);
        const glm::dvec3 predicted = albedo_[static_cast<std::size_t>(samples_->segment[i])] * shading / kPi;
        const double relative =
            (luminance(samples_->radiance[i]) - luminance(predicted)) / std::max(luminance(predicted), 1e-3);
        weight_[i] = relative; // kept for the second pass below
        scratch_.push_back(std::abs(relative));
    }
    if (scratch_.empty()) return;
    const auto middle = scratch_.begin() + static_cast<std::ptrdiff_t>(scratch_.size() / 2);
    std::nth_element(scratch_.begin(), middle, scratch_.end());
    const double scale = kTukeyConstant * std::max(kMadToSigma * *middle, kMinRelativeScale);
    for (const std::size_t i : fitIndex_) {
        const double t = weight_[i] / scale;
        weight_[i] = std::abs(t) < 1.0 ? (1.0 - t * t) * (1.0 - t * t) : 0.0;
    }
}

// Albedo per segment given the shading, then the reference segment brought back to referenceAlbedo
// (the shading takes the inverse factor, so the prediction is unchanged).
void LightModelFit::updateAlbedo(const FreeLight& light, std::array<glm::dvec3, kMaxColumns>& beta) noexcept {
    std::array<glm::dvec3, kMaxSegments> numerator{}, denominator{};
    for (const std::size_t i : fitIndex_) {
        if (weight_[i] <= 0.0) continue;
        const glm::dvec3 shading = shadingAt(i, light, beta);
        const auto s = static_cast<std::size_t>(samples_->segment[i]);
        numerator[s] += weight_[i] * kPi * samples_->radiance[i] * shading;
        denominator[s] += weight_[i] * shading * shading;
    }
    for (std::size_t s = 0; s < static_cast<std::size_t>(segmentCount_); ++s) {
        const glm::dvec3 albedo = numerator[s] / denominator[s];
        if (glm::all(glm::greaterThan(albedo, glm::dvec3(1e-4))) && std::isfinite(albedo.x + albedo.y + albedo.z))
            albedo_[s] = albedo;
    }
    const glm::dvec3 toReference = options_->referenceAlbedo / albedo_[0];
    for (std::size_t s = 0; s < static_cast<std::size_t>(segmentCount_); ++s) albedo_[s] *= toReference;
    for (int c = 0; c < columnCount(); ++c) beta[static_cast<std::size_t>(c)] /= toReference;
}

double LightModelFit::residual(const FreeLight& light, const std::array<glm::dvec3, kMaxColumns>& beta) const noexcept {
    double squares = 0.0, observed = 0.0;
    for (const std::size_t i : fitIndex_) {
        const glm::dvec3 shading = shadingAt(i, light, beta);
        const glm::dvec3 error =
            samples_->radiance[i] - albedo_[static_cast<std::size_t>(samples_->segment[i])] * shading / kPi;
        squares += weight_[i] * glm::dot(error, error);
        observed += weight_[i] * glm::dot(samples_->radiance[i], samples_->radiance[i]);
    }
    return observed > 0.0 ? std::sqrt(squares / observed) : 0.0;
}

void LightModelFit::selectSamples(int segments) {
    std::size_t candidates = 0;
    for (std::size_t i = 0; i < samples_->size(); ++i)
        candidates += samples_->segment[i] >= 0 && samples_->segment[i] < segments ? 1U : 0U;
    // Every n-th candidate, so that the fit sees at most maxFitSamples spread over the whole image.
    const std::size_t fitEvery =
        std::max<std::size_t>(1, (candidates + static_cast<std::size_t>(options_->maxFitSamples) - 1) /
                                     static_cast<std::size_t>(options_->maxFitSamples));
    fitIndex_.clear();
    for (std::size_t i = 0, candidate = 0; i < samples_->size(); ++i)
        if (samples_->segment[i] >= 0 && samples_->segment[i] < segments && candidate++ % fitEvery == 0)
            fitIndex_.push_back(i);
    const std::size_t every = std::max<std::size_t>(1, fitIndex_.size() / kSearchSamples);
    searchIndex_.clear();
    for (std::size_t j = 0; j < fitIndex_.size(); j += every) searchIndex_.push_back(fitIndex_[j]);
}

// Model selection by two-fold cross-validation over image blocks: each light (the free light, then each emitter)
// stays only if the model with it, its linear coefficients fitted on one half of the blocks, predicts the other half
// better than the model without it, consistently over the blocks. A real light's shading continues across surfaces;
// a light that only fits texture (a clipped white surface taken for a lamp, a free light bent onto a poster) does not
// carry over to other blocks, or helps only the few blocks around it. (A comparison of the in-sample residuals needs a
// threshold that depends on how much texture the segments hold: on a textured room a real light takes only ~20 % of
// the residual the rest of the model leaves, a spurious one up to 6 %.)
// The test: d_b = held-out squared error without the light minus with it, per block b (B blocks with samples); the
// light stays if mean(d) > kMinTStatistic * sd(d) / sqrt(B), a one-sided paired t-test at ~2.3 % with t = 2 (blocks
// as the independent units: texture and depth noise are correlated within a block, not across 64 pixels).
bool LightModelFit::selectLights(const FreeLight& light, std::array<glm::dvec3, kMaxColumns>& beta) {
    constexpr double kMinTStatistic = 2.0;
    // Blocks of 64 x 64 pixels in a checkerboard: larger than a texture's usual grain (wood, carpet, print), small
    // enough that each fold holds every large surface.
    constexpr int kBlockPixels = 64;
    const int width = std::max(samples_->imageWidth, 1);
    const int blocksPerRow = (width + kBlockPixels - 1) / kBlockPixels;
    foldIndex_[0].clear();
    foldIndex_[1].clear();
    sampleBlock_.assign(samples_->size(), 0);
    int blockCount = 0;
    for (const std::size_t i : fitIndex_) {
        const int pixel = samples_->pixelIndex[i];
        const int bu = pixel % width / kBlockPixels, bv = pixel / width / kBlockPixels;
        sampleBlock_[i] = bv * blocksPerRow + bu;
        blockCount = std::max(blockCount, sampleBlock_[i] + 1);
        foldIndex_[static_cast<std::size_t>((bu + bv) % 2)].push_back(i);
    }
    const bool canValidate = foldIndex_[0].size() >= static_cast<std::size_t>(kMinFoldSamples) &&
                             foldIndex_[1].size() >= static_cast<std::size_t>(kMinFoldSamples);
    // Held-out squared error per block of the model as lightEnabled_ says, each fold predicted from the other.
    const auto heldOutError = [&](std::vector<double>& blockError) {
        blockError.assign(static_cast<std::size_t>(blockCount), 0.0);
        std::array<glm::dvec3, kMaxColumns> foldBeta{};
        for (std::size_t fold = 0; fold < 2; ++fold) {
            fitIndex_.swap(foldIndex_[fold]);
            const bool solved = solveLinear(light, foldBeta);
            fitIndex_.swap(foldIndex_[fold]);
            if (!solved) return false;
            for (const std::size_t i : foldIndex_[1 - fold]) {
                const glm::dvec3 error =
                    samples_->radiance[i] -
                    albedo_[static_cast<std::size_t>(samples_->segment[i])] * shadingAt(i, light, foldBeta) / kPi;
                blockError[static_cast<std::size_t>(sampleBlock_[i])] += weight_[i] * glm::dot(error, error);
            }
        }
        return true;
    };
    const auto improvesHeldOut = [&]() {
        double sum = 0.0, squares = 0.0;
        int blocks = 0;
        for (std::size_t b = 0; b < blockErrorWith_.size(); ++b) {
            const double d = blockErrorWithout_[b] - blockErrorWith_[b];
            if (blockErrorWithout_[b] == 0.0 && blockErrorWith_[b] == 0.0) continue; // no samples
            sum += d;
            squares += d * d;
            ++blocks;
        }
        if (blocks < 2 || !std::isfinite(sum + squares)) return false;
        const double mean = sum / blocks;
        const double variance = std::max(squares / blocks - mean * mean, 0.0) * blocks / (blocks - 1.0);
        return mean > kMinTStatistic * std::sqrt(variance / blocks);
    };
    std::array<glm::dvec3, kMaxColumns> without{};
    for (std::size_t c = 0; c < static_cast<std::size_t>(1 + emitterCount_); ++c) {
        bool keep = false;
        if (canValidate) {
            const bool withSolved = heldOutError(blockErrorWith_);
            lightEnabled_[c] = false;
            keep = withSolved && heldOutError(blockErrorWithout_) && improvesHeldOut();
        }
        lightEnabled_[c] = keep;
        if (keep) continue;
        if (!solveLinear(light, without)) return false;
        for (int iteration = 0; iteration < 2; ++iteration) {
            updateWeights(light, without);
            updateAlbedo(light, without);
            if (!solveLinear(light, without)) return false;
        }
        beta = without;
    }
    return true;
}

bool LightModelFit::run(const SurfaceSamples& samples, int segmentCount,
                        const std::array<AreaEmitter, kMaxEmitters>& emitters, int emitterCount,
                        const glm::dvec3& reference, const std::optional<FreeLight>& warmStart,
                        const RoomLightOptions& options, ModelFitResult& result) {
    samples_ = &samples;
    options_ = &options;
    lightEnabled_.fill(true);
    emitters_ = emitters;
    emitterCount_ = emitterCount;
    cacheFixedColumns();
    emitters_ = emitters;
    emitterCount_ = emitterCount;
    segmentCount_ = segmentCount;
    reference_ = reference;
    std::array<glm::dvec3, kMaxSegments> meanColour{};
    std::array<int, kMaxSegments> members{};
    for (std::size_t i = 0; i < samples.size(); ++i) {
        if (samples.segment[i] < 0) continue;
        meanColour[static_cast<std::size_t>(samples.segment[i])] += samples.radiance[i];
        ++members[static_cast<std::size_t>(samples.segment[i])];
    }
    if (segmentCount < 1 || members[0] < options.minSamples) return false;
    weight_.assign(samples.size(), 1.0);
    scratch_.reserve(samples.size());
    // Start: segments as bright as they look relative to the reference (the same average light on each).
    const glm::dvec3 referenceMean = meanColour[0] / static_cast<double>(members[0]);
    for (std::size_t s = 0; s < static_cast<std::size_t>(segmentCount); ++s)
        albedo_[s] = options.referenceAlbedo * (meanColour[s] / static_cast<double>(members[s])) / referenceMean;

    // The light's geometry from the albedo-free search over all segments, its strength and the ambient from the
    // reference segment alone (albedo known, so linear), then the other segments' albedos from that shading, then
    // all segments, alternating light and albedo.
    constexpr double kDegree = kPi / 180.0;
    selectSamples(segmentCount);
    FreeLight light =
        warmStart ? patternSearch(*warmStart, 2.0 * kDegree, 0.05) : patternSearch(globalSearch(), 8.0 * kDegree, 0.2);
    std::array<glm::dvec3, kMaxColumns> beta{};
    selectSamples(1);
    for (int iteration = 0; iteration < 2; ++iteration) {
        if (!solveLinear(light, beta)) return false;
        updateWeights(light, beta);
    }
    selectSamples(segmentCount);
    updateAlbedo(light, beta);
    for (int pass = 0; pass < 2; ++pass) {
        // A cold start refines the light once more with the albedos it fixed; a warm one already had last frame's.
        if (pass == 0 && !warmStart) light = patternSearch(light, 2.0 * kDegree, 0.05);
        for (int iteration = 0; iteration < 3; ++iteration) {
            if (!solveLinear(light, beta)) return false;
            updateWeights(light, beta);
            updateAlbedo(light, beta);
        }
    }
    if (!solveLinear(light, beta)) return false;
    if (!selectLights(light, beta)) return false;
    result.light = light;
    result.lightIrradiance = beta[0];
    for (int e = 0; e < emitterCount; ++e)
        result.emitterRadiance[static_cast<std::size_t>(e)] = beta[static_cast<std::size_t>(1 + e)];
    for (int k = 0; k < kShCount; ++k)
        result.ambientRadiance[static_cast<std::size_t>(k)] = beta[static_cast<std::size_t>(1 + emitterCount + k)];
    result.albedo = albedo_;
    result.residual = residual(light, beta);
    result.samplesFitted = static_cast<int>(fitIndex_.size());
    return std::isfinite(result.residual);
}

} // namespace lightskin::roomlight
