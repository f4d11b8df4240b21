#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/gi/common/ValSetMerger.h>

#include <algorithm>
#include <string>

namespace lightskin::gi {

ValSetMerger ValSetMerger::create(std::uint32_t capacity) {
    LIGHTSKIN_ASSERT(capacity > 0, "capacity must be positive");
    ValSetMerger merger;
    merger.capacity_ = capacity;
    merger.buffer_ = gl::Buffer::create(GLsizeiptr(capacity) * GLsizeiptr(sizeof(VirtualAreaLight)));
    return merger;
}

ValSetView ValSetMerger::merge(std::span<const ValSetView> sets) {
    LIGHTSKIN_ASSERT(buffer_, "ValSetMerger used before create()");
    std::uint32_t count = 0;
    dropped_ = 0;
    constexpr auto stride = GLsizeiptr(sizeof(VirtualAreaLight));
    for (const ValSetView& set : sets) {
        const std::uint32_t fits = std::min(set.count, capacity_ - count);
        dropped_ += set.count - fits;
        if (fits == 0) continue;
        LIGHTSKIN_ASSERT(set.buffer != 0, "a non-empty VAL set without a buffer");
        glCopyNamedBufferSubData(set.buffer, buffer_.id(), 0, GLintptr(count) * stride, GLsizeiptr(fits) * stride);
        count += fits;
    }
    if (dropped_ > 0)
        log::warning("ValSetMerger: " + std::to_string(dropped_) + " VALs beyond the capacity of " +
                     std::to_string(capacity_) + " were dropped");
    return {buffer_.id(), count};
}

} // namespace lightskin::gi
