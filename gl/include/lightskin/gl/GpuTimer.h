#pragma once
// GPU stage timing with GL timestamp queries (GL_TIMESTAMP via glQueryCounter), so stages may be
// timed back to back without the nesting limits of GL_TIME_ELAPSED. Queries are created once; a
// frame's begin()/end() pairs reuse them (no allocation per frame).

#include <lightskin/gl/Objects.h>

#include <string>
#include <vector>

namespace lightskin::gl {

struct StageTime {
    std::string name;
    double milliseconds = 0.0;
};

class GpuStageTimer {
public:
    GpuStageTimer() = default;
    /// Needs a current context. `maxStages` bounds the begin()/end() pairs per frame.
    static GpuStageTimer create(int maxStages);

    /// Forgets the previous frame's stages.
    void beginFrame();
    /// Starts timing `name` (a string literal or a string that outlives collect()).
    void begin(const char* name);
    void end();
    /// Waits for the frame's queries and writes one entry per stage, in begin() order, into `out`
    /// (resized; its strings keep their capacity across frames).
    void collect(std::vector<StageTime>& out);

private:
    std::vector<Query> startQueries_, endQueries_;
    std::vector<const char*> names_;
    int used_ = 0;
    bool open_ = false;
};

} // namespace lightskin::gl
