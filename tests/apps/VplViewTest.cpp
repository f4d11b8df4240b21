// `lightskin replay --view vpl` on the bundled synthetic recording: the interpolated per-vertex
// diffuse VPLs (eq. 13) drawn over the with-GI composite. The view must leave the composite
// untouched except where its segments and dots are drawn, and the VPLs it draws must be finite.
#include "TestPaths.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstdlib>
#include <fstream>
#include <sys/wait.h>

namespace fs = std::filesystem;
using namespace lightskin;

namespace {

/// Replays the first frame of recordings/synth-orbit with `view` into scratch/<view>; returns the exit code.
int replayFirstFrame(const std::string& view, const fs::path& scratch) {
    const fs::path root = test::sourceDir(), out = scratch / view;
    const std::string command = std::string(LIGHTSKIN_PROGRAM) + " replay " + (root / "recordings" / "synth-orbit").string() +
                                " --scene " + (root / "recordings" / "scenes" / "orbit.json").string() + " --out " + out.string() +
                                " --max-frames 1 --no-video --no-compare --view " + view + " > " + (scratch / (view + ".out")).string() +
                                " 2> " + (scratch / (view + ".err")).string();
    return test::runShell(command);
}

} // namespace

TEST(VplView, DrawsFiniteVertexVplsOverTheFinalCompositeOnly) {
    const fs::path scratch = test::scratchDir("vpl_view");
    ASSERT_EQ(replayFirstFrame("final", scratch), 0) << test::readText(scratch / "final.err");
    ASSERT_EQ(replayFirstFrame("vpl", scratch), 0) << test::readText(scratch / "vpl.err");

    const nlohmann::json finalReport = nlohmann::json::parse(test::readText(scratch / "final" / "report.json"));
    const nlohmann::json vplReport = nlohmann::json::parse(test::readText(scratch / "vpl" / "report.json"));
    ASSERT_EQ(vplReport["framesRead"], 1);
    const nlohmann::json& frame = vplReport["frames"][0];
    EXPECT_FALSE(finalReport["frames"][0].contains("vplSegments")); // only the vpl view reads the VPLs back
    ASSERT_TRUE(frame.contains("vplSegments")) << frame.dump();
    const std::int64_t segments = frame["vplSegments"].get<std::int64_t>();
    // orbit.json: bunny (453 vertices at res4) + cube, all lit by the room; at most 2000 are drawn.
    EXPECT_GT(segments, 100);
    EXPECT_LE(segments, 2000);
    EXPECT_EQ(frame["vplNonFinite"].get<std::int64_t>(), 0);

    const cv::Mat finalImage = cv::imread((scratch / "final" / "frames" / "000000.png").string(), cv::IMREAD_COLOR);
    const cv::Mat vplImage = cv::imread((scratch / "vpl" / "frames" / "000000.png").string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(finalImage.empty());
    ASSERT_EQ(vplImage.size(), finalImage.size());
    std::int64_t changed = 0;
    for (int v = 0; v < finalImage.rows; ++v)
        for (int u = 0; u < finalImage.cols; ++u) changed += finalImage.at<cv::Vec3b>(v, u) != vplImage.at<cv::Vec3b>(v, u) ? 1 : 0;
    EXPECT_GT(changed, 0);
    // A segment is a quarter of the way to its VPL (the room, a few metres away) and a dot is at most
    // 3x3 pixels: far fewer changed pixels than segments x a generous 80 px, and well below the image.
    EXPECT_LE(changed, segments * 80);
    EXPECT_LT(changed, std::int64_t(finalImage.total() / 2));
}
