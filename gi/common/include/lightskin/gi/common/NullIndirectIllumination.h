#pragma once
// The "none" GI technique: writes zero indirect light. Used when a scene asks for no GI, and by the
// pipeline until a real technique is available, so that everything before and after GI runs alone.

#include <lightskin/gi/common/IndirectIllumination.h>

namespace lightskin::render {

class NullIndirectIllumination final : public gi::IndirectIllumination {
public:
    std::string_view name() const override { return "none"; }
    void prepare(std::span<const gi::MeshInstance>) override {}
    void render(const gi::ValSetView& lights, std::span<const gi::MeshInstance> instances, const gi::GBufferView& gbuffer,
                const gi::ViewParameters& view, std::uint32_t targetTexture) override;
    void lastStageTimes(std::vector<gl::StageTime>& out) const override { out.clear(); }
};

} // namespace lightskin::render
