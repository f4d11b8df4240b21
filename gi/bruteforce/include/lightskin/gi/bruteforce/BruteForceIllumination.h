#pragma once
// The paper's comparison (section 6): every VAL applied to every covered G-buffer pixel (eq. 2
// with 4 and 5), no interpolation, no occlusion. Additive fragment passes of K_cache VALs read
// from a uniform buffer. Same formulas as LightSkin (gi/lightskin/shaders/lightskin_math.glsl); units too.

#include <lightskin/gi/common/IndirectIllumination.h>

#include <memory>
#include <numbers>

namespace lightskin::gi {

struct BruteForceSettings {
    int kCache = 128;                                         ///< VALs per pass (multiple of 16)
    bool glossy = true;                                       ///< add the glossy term (eq. 5)
    float cParameter = float(1.0 / (2.0 * std::numbers::pi)); ///< c of c_k = c (k+1), 1/sr
    std::uint32_t valCapacity = 1u << 16;                     ///< reserved in prepare(), grows if exceeded
    /// Guard G12 of lightskin_math.glsl: VALs within 4 of their radii of a pixel integrated as areas
    /// (LightSkinSettings::nearFieldArea); false = the point model (the default, for its cost).
    bool nearFieldArea = false;
};

class BruteForceIllumination final : public IndirectIllumination {
public:
    /// Needs a current GL 4.5 context. Throws lightskin::Error on a bad kCache.
    static std::unique_ptr<BruteForceIllumination> create(const BruteForceSettings& settings);
    ~BruteForceIllumination() override;

    std::string_view name() const override { return "brute-force"; }
    Technique technique() const noexcept override { return Technique::BruteForce; }
    TechniqueCapabilities capabilities() const noexcept override {
        return {.glossy = true, .occlusion = false, .sparsePoints = false, .vertexVpls = false, .cpuStages = {}};
    }
    void prepare(std::span<const MeshInstance> instances) override;
    void render(const ValSetView& lights, std::span<const MeshInstance> instances, const GBufferView& gbuffer,
                const ViewParameters& view, std::uint32_t targetTexture) override;
    void lastStageTimes(std::vector<gl::StageTime>& out) const override;

private:
    BruteForceIllumination();
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace lightskin::gi
