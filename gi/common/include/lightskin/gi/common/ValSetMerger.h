#pragma once
// Puts several VAL sets (depth VALs of the real scene, RSM VALs of each virtual light) back to back
// into one packed set, the single input of an indirect-illumination technique. GPU-side copies, no
// read-back; the buffer is sized once.

#include <lightskin/gi/common/VirtualAreaLight.h>
#include <lightskin/gl/Objects.h>

#include <cstdint>
#include <span>

namespace lightskin::gi {

class ValSetMerger {
public:
    ValSetMerger() = default;
    /// Needs a current GL context; `capacity` > 0 VALs.
    static ValSetMerger create(std::uint32_t capacity);

    /// Copies `sets` in order. VALs beyond the capacity are dropped (see lastDropped()); the
    /// returned set is valid until the next merge().
    ValSetView merge(std::span<const ValSetView> sets);

    std::uint32_t capacity() const noexcept { return capacity_; }
    /// VALs that did not fit in the last merge() (0 normally).
    std::uint32_t lastDropped() const noexcept { return dropped_; }

private:
    gl::Buffer buffer_;
    std::uint32_t capacity_ = 0, dropped_ = 0;
};

} // namespace lightskin::gi
