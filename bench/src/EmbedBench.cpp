// `lightskin bench-embed`: what embedding costs on top of the pipeline, and what a frame budget
// picks on a real recording. A benchmark, not a test: results go to docs/BENCHMARKS.md with the
// command line that produced them.
//
// Part 1, per frame side by side (wall clock, glFinish before and after each measured call): the
// session's frame (process), render() VirtualOnly into a host framebuffer with depth, render() of the
// composite, and gl::StateGuard alone (save + restore, the overhead every session call carries).
// Part 2: the same recording with each --budgets value: the settings chosen after warm-up, and the
// median frame time against the budget.

#include <lightskin/bench/EmbedBench.h>
#include <lightskin/bench/StopRequest.h>
#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/gl/Context.h>
#include <lightskin/gl/StateGuard.h>
#include <lightskin/mr/Session.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

namespace lightskin::bench {

namespace {

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

template <typename F>
double timedMs(F&& f) {
    glFinish();
    const auto start = std::chrono::steady_clock::now();
    f();
    glFinish();
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

} // namespace

int runEmbedBench(const EmbedBenchOptions& o) {
    StopCheck stop(o.stopRequested);
    auto context = gl::createHeadlessContext();
    std::printf("bench-embed: %s, %s on %s\n", o.recording.c_str(), o.scene.c_str(), context->describe().c_str());
    std::fflush(stdout);
    {
        auto session =
            mr::Session::create({}, mr::SceneInput::fromFile(o.scene), capture::openFrameSource(o.recording, {}));
        const CameraIntrinsics& k = session->camera();
        const gl::Texture colour = gl::Texture::create2D(GL_RGBA8, k.width, k.height);
        const gl::Renderbuffer depth = gl::Renderbuffer::create(GL_DEPTH_COMPONENT32F, k.width, k.height);
        gl::Framebuffer host = gl::Framebuffer::create();
        host.attach(GL_COLOR_ATTACHMENT0, colour);
        host.attach(GL_DEPTH_ATTACHMENT, depth);
        host.checkComplete("bench host framebuffer");
        std::vector<double> frame, virtualOnly, composite, guard;
        for (int f = 0; f < o.frames && !stop(); ++f) {
            bool more = true;
            frame.push_back(timedMs([&] { more = session->processNext(); }));
            if (!more) break;
            virtualOnly.push_back(timedMs([&] { session->render({.framebuffer = host.id(), .depthTest = true}); }));
            composite.push_back(timedMs([&] {
                session->render({.framebuffer = host.id(), .content = mr::RenderContent::CompositeOverCamera});
            }));
            guard.push_back(timedMs([] {
                                for (int i = 0; i < 100; ++i) const gl::StateGuard g;
                            }) /
                            100.0);
        }
        std::printf("\n| %dx%d, %zu frames, median ms | frame (process) | render virtual-only + depth | render "
                    "composite | StateGuard save+restore |\n|---|---|---|---|---|\n",
                    k.width, k.height, frame.size());
        std::printf("| %s | %.1f | %.2f | %.2f | %.3f |\n", mr::describe(session->report().settings).c_str(),
                    median(frame), median(virtualOnly), median(composite), median(guard));
        std::fflush(stdout);
    }
    if (stop.stopped()) {
        printInterrupted("bench-embed");
        return 0;
    }
    std::printf("\n| budget ms | settings after warm-up (frames %d..%d) | median frame ms | frames over budget "
                "|\n|---|---|---|---|\n",
                o.warmUp, o.frames - 1);
    for (double budget : o.budgets) {
        if (stop()) break;
        mr::SessionOptions options;
        options.budgetMs = budget;
        auto session =
            mr::Session::create(options, mr::SceneInput::fromFile(o.scene), capture::openFrameSource(o.recording, {}));
        std::vector<double> times;
        std::map<std::string, int> chosen;
        int over = 0;
        for (int f = 0; f < o.frames && !stop() && session->processNext(); ++f) {
            if (f < o.warmUp) continue;
            times.push_back(session->report().totalMs);
            over += session->report().totalMs > budget ? 1 : 0;
            ++chosen[mr::describe(session->report().settings)];
        }
        if (times.empty() && stop.stopped()) break; // stopped during the warm-up: nothing measured
        std::string settings;
        for (const auto& [name, count] : chosen)
            settings += (settings.empty() ? "" : "; ") + name + " (" + std::to_string(count) + ")";
        std::printf("| %.0f | %s | %.1f | %d of %zu |\n", budget, settings.c_str(), median(times), over, times.size());
        std::fflush(stdout);
    }
    if (stop()) printInterrupted("bench-embed");
    return 0;
}

} // namespace lightskin::bench
