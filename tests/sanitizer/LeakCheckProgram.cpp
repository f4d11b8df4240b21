// Sanitizer builds only: proves that cmake/sanitizers/lsan.supp does not hide leaks in lightskin's own code.
// It does what the GL and .oni tests do (a headless GL context with Mesa's driver loaded and kept mapped, an
// .oni opened and read through OpenNI2) and then, unless run with --clean, leaks three things of ours:
//   - a plain allocation in this program (leakPlainBuffer),
//   - a whole GL context (gl::createHeadlessContext), which holds Mesa objects,
//   - a whole .oni frame source (capture::openFrameSource), which holds OpenNI2 objects.
// tests/sanitizer/CheckLeakReport.cmake runs it under the suppressions and requires LeakSanitizer to fail the
// run and to name each of the three allocation sites; the --clean run must pass, so the failure comes from
// these leaks and nothing else. (With the source leaked, OpenNI2 is never shut down and its PS1080/PSLink
// drivers then report small leaks of their own too; the clean run shows that they do not otherwise.)
#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/RgbdFrame.h>
#include <lightskin/gl/Context.h>

#include <epoxy/gl.h>

#include <cstdio>
#include <cstring>
#include <memory>
#include <string>

namespace {

// Written through a volatile pointer so the compiler cannot drop the allocations, then cleared, so nothing
// references them any more when LeakSanitizer scans the process at exit.
void* volatile lastLeak = nullptr;

[[gnu::noinline]] void leakPlainBuffer() {
    auto* buffer = new unsigned char[4321];
    std::memset(buffer, 1, 4321);
    lastLeak = buffer;
    lastLeak = nullptr;
}

[[gnu::noinline]] void exerciseGl(bool leak) {
    auto context = lightskin::gl::createHeadlessContext();
    context->makeCurrent();
    GLuint buffer = 0;
    glCreateBuffers(1, &buffer);
    glNamedBufferData(buffer, 1024, nullptr, GL_STATIC_DRAW);
    glDeleteBuffers(1, &buffer);
    glFinish();
    if (leak) {
        lastLeak = context.release();
        lastLeak = nullptr;
    }
}

[[gnu::noinline]] void exerciseOni(const std::string& oniPath, bool leak) {
    auto source = lightskin::capture::openFrameSource(oniPath);
    lightskin::RgbdFrame frame;
    if (!source->next(frame)) std::fprintf(stderr, "no frame in %s\n", oniPath.c_str());
    if (leak) {
        lastLeak = source.release();
        lastLeak = nullptr;
    }
}

} // namespace

int main(int argc, char** argv) {
    const bool clean = argc == 3 && std::strcmp(argv[2], "--clean") == 0;
    if (argc < 2 || argc > 3 || (argc == 3 && !clean)) {
        std::fprintf(stderr, "usage: %s <file.oni> [--clean]\n", argv[0]);
        return 2;
    }
    exerciseGl(!clean);
    exerciseOni(argv[1], !clean);
    if (!clean) leakPlainBuffer();
    // stderr: LeakSanitizer ends the process before stdout's buffer would be flushed.
    std::fprintf(stderr, "lightskin leak check: finished (%s)\n", clean ? "clean" : "with deliberate leaks");
    return 0;
}
