#pragma once
// The "none" GI technique: writes zero indirect light. Used when a scene asks for no GI, and by the
// pipeline until a real technique is available, so that everything before and after GI runs alone.

#include <lightskin/gi/common/IndirectIllumination.h>

namespace lightskin::gi {

class NullIndirectIllumination final : public IndirectIllumination {
public:
    std::string_view name() const override { return "none"; }
    Technique technique() const noexcept override { return Technique::None; }
    void prepare(std::span<const MeshInstance>) override {}
    void render(const ValSetView& lights, std::span<const MeshInstance> instances, const GBufferView& gbuffer,
                const ViewParameters& view, std::uint32_t targetTexture) override;
    void lastStageTimes(std::vector<gl::StageTime>& out) const override { out.clear(); }
};

} // namespace lightskin::gi
