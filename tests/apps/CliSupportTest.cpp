// ThirdPartyOutputCapture (apps/lightskin/CliSupport.h) in a child process whose standard error is a
// file: what libraries write to descriptor 2 directly, not through C's `stderr`, is captured too.
#include "CliSupport.h"

#include "TestPaths.h"

#include <lightskin/core/Log.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

using namespace lightskin;
namespace fs = std::filesystem;

namespace {

void writeRaw(const char* text) {
    const ssize_t n = ::write(STDERR_FILENO, text, std::strlen(text));
    if (n != static_cast<ssize_t>(std::strlen(text))) ::_exit(3);
}

/// Runs `body` with a capture alive in a child whose descriptor 2 is `file`; returns the file's text.
std::string stderrOfChild(const fs::path& file, log::Level level, void (*body)()) {
    const pid_t child = ::fork();
    if (child == 0) {
        const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd < 0 || ::dup2(fd, STDERR_FILENO) < 0) ::_exit(2);
        ::close(fd);
        log::setLevel(level);
        {
            const apps::ThirdPartyOutputCapture capture;
            body();
        }
        std::fflush(nullptr);
        ::_exit(0);
    }
    int status = 0;
    EXPECT_EQ(::waitpid(child, &status, 0), child);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
    return test::readText(file);
}

bool hasLine(const std::string& text, const std::string& line) {
    return text.rfind(line + "\n", 0) == 0 || text.find("\n" + line + "\n") != std::string::npos;
}

void writeBothWays() {
    writeRaw("libpng warning: written to descriptor 2 itself\n");
    writeRaw("our own line on descriptor 2\n");
    writeRaw("Assimp: a partial "); // one line in two writes
    writeRaw("line, then its end\n");
    std::fprintf(stderr, "libpng error: through C's stderr\n");
    std::fprintf(stderr, "our own line through stderr\n");
}

} // namespace

// A library that writes to descriptor 2 directly (write(2, ...)) is captured like one that
// uses C's `stderr`: no raw line on the terminal, the line in the log with its source; our own lines
// pass unchanged whichever way they are written.
TEST(ThirdPartyOutputCapture, CoversWritesToDescriptorTwo) {
    const fs::path scratch = test::scratchDir("cli_support_fd");
    const std::string debug = stderrOfChild(scratch / "debug.txt", log::Level::Debug, &writeBothWays);
    EXPECT_FALSE(hasLine(debug, "libpng warning: written to descriptor 2 itself")) << debug;
    EXPECT_NE(debug.find("[debug] libpng: libpng warning: written to descriptor 2 itself\n"), std::string::npos)
        << debug;
    EXPECT_NE(debug.find("[debug] assimp: Assimp: a partial line, then its end\n"), std::string::npos) << debug;
    EXPECT_NE(debug.find("[debug] libpng: libpng error: through C's stderr\n"), std::string::npos) << debug;
    EXPECT_TRUE(hasLine(debug, "our own line on descriptor 2")) << debug;
    EXPECT_TRUE(hasLine(debug, "our own line through stderr")) << debug;

    // Without -v the libraries' lines are not shown at all; ours are.
    const std::string info = stderrOfChild(scratch / "info.txt", log::Level::Info, &writeBothWays);
    EXPECT_EQ(info.find("libpng"), std::string::npos) << info;
    EXPECT_EQ(info.find("Assimp"), std::string::npos) << info;
    EXPECT_TRUE(hasLine(info, "our own line on descriptor 2")) << info;
    EXPECT_TRUE(hasLine(info, "our own line through stderr")) << info;
}

// After the capture, descriptor 2 is the file again (nothing is left pointing at the closed pipe).
TEST(ThirdPartyOutputCapture, PutsDescriptorTwoBack) {
    const fs::path scratch = test::scratchDir("cli_support_restore");
    const std::string text = stderrOfChild(scratch / "after.txt", log::Level::Info, [] {});
    EXPECT_EQ(text, "");
    const pid_t child = ::fork();
    if (child == 0) {
        const int fd = ::open((scratch / "after2.txt").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd < 0 || ::dup2(fd, STDERR_FILENO) < 0) ::_exit(2);
        ::close(fd);
        { const apps::ThirdPartyOutputCapture capture; }
        writeRaw("libpng warning: after the capture\n");
        ::_exit(0);
    }
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
    EXPECT_EQ(test::readText(scratch / "after2.txt"), "libpng warning: after the capture\n");
}
