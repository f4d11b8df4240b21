#include <lightskin/core/Error.h>
#include <lightskin/gl/GpuTimer.h>

namespace lightskin::gl {

GpuStageTimer GpuStageTimer::create(int maxStages) {
    LIGHTSKIN_ASSERT(maxStages > 0, "maxStages must be positive");
    GpuStageTimer timer;
    for (int i = 0; i < maxStages; ++i) {
        timer.startQueries_.push_back(Query::create(GL_TIMESTAMP));
        timer.endQueries_.push_back(Query::create(GL_TIMESTAMP));
    }
    timer.names_.resize(std::size_t(maxStages), nullptr);
    return timer;
}

void GpuStageTimer::beginFrame() {
    used_ = 0;
    open_ = false;
}

void GpuStageTimer::begin(const char* name) {
    LIGHTSKIN_ASSERT(!open_, "end() the previous stage first");
    LIGHTSKIN_ASSERT(std::size_t(used_) < names_.size(), "more stages than maxStages");
    names_[std::size_t(used_)] = name;
    glQueryCounter(startQueries_[std::size_t(used_)].id(), GL_TIMESTAMP);
    open_ = true;
}

void GpuStageTimer::end() {
    LIGHTSKIN_ASSERT(open_, "begin() a stage first");
    glQueryCounter(endQueries_[std::size_t(used_)].id(), GL_TIMESTAMP);
    ++used_;
    open_ = false;
}

void GpuStageTimer::collect(std::vector<StageTime>& out) {
    LIGHTSKIN_ASSERT(!open_, "end() the last stage before collect()");
    out.resize(std::size_t(used_));
    for (std::size_t i = 0; i < std::size_t(used_); ++i) {
        GLuint64 start = 0, stop = 0;
        glGetQueryObjectui64v(startQueries_[i].id(), GL_QUERY_RESULT, &start);
        glGetQueryObjectui64v(endQueries_[i].id(), GL_QUERY_RESULT, &stop);
        out[i].name.assign(names_[i]);
        out[i].milliseconds = stop > start ? double(stop - start) * 1e-6 : 0.0;
    }
}

} // namespace lightskin::gl
