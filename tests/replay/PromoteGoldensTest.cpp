// scripts/promote_goldens.sh: promotion takes named goldens only, shows old against new (both
// renderers, means, the metrics the test computed) and writes a diff image, and copies nothing
// without an explicit --accept. Runs the script on goldens made here, never on the real ones.
#include "TestPaths.h"

#include <lightskin/eval/GoldenImage.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <string>

namespace fs = std::filesystem;

namespace lightskin::test {
namespace {

struct Promotion {
    fs::path scratch, goldens, actualFolder;
};

/// An old golden and a new actual image 10 % brighter on its content, written the way the replay
/// suite writes them (NAME.actual.png with its coverage under <case>/golden/).
Promotion makeCandidate(const std::string& test) {
    Promotion p;
    p.scratch = scratchDir(test);
    p.goldens = p.scratch / "goldens";
    p.actualFolder = p.scratch / "actual" / "replay_case" / "golden";
    cv::Mat old = cv::Mat::zeros(16, 24, CV_32FC3), coverage = cv::Mat::zeros(16, 24, CV_8UC1);
    old(cv::Rect(4, 4, 10, 8)).setTo(cv::Scalar(0.2, 0.3, 0.4));
    coverage(cv::Rect(4, 4, 10, 8)).setTo(255);
    eval::writeLinearPng16(p.goldens / "case_final_0.png", old, "old renderer");
    const eval::GoldenResult result = eval::compareWithGolden(1.1 * old, p.goldens, "case_final_0", {}, p.actualFolder,
                                                              {"new renderer", coverage, {}});
    EXPECT_FALSE(result.passed);
    return p;
}

int promote(const Promotion& p, const std::string& arguments, const std::string& tag) {
    const std::string command = (sourceDir() / "scripts" / "promote_goldens.sh").string() + " --actual " +
                                (p.scratch / "actual").string() + " --goldens " + p.goldens.string() + " --lightskin " +
                                LIGHTSKIN_PROGRAM + " " + arguments + " > " + (p.scratch / (tag + ".out")).string() +
                                " 2> " + (p.scratch / (tag + ".err")).string();
    return runShell(command);
}

TEST(PromoteGoldensTest, RefusesWithoutAcceptAfterShowingOldAgainstNewAndTheDiff) {
    const Promotion p = makeCandidate("promote_refuses");
    const std::string before = readText(p.goldens / "case_final_0.png");
    ASSERT_FALSE(before.empty());
    EXPECT_EQ(promote(p, "case_final_0", "refused"), 3);
    const std::string out = readText(p.scratch / "refused.out"), err = readText(p.scratch / "refused.err");
    EXPECT_NE(out.find("old renderer"), std::string::npos) << out;
    EXPECT_NE(out.find("new renderer"), std::string::npos) << out;
    EXPECT_NE(out.find("DIFFERENT RENDERER"), std::string::npos) << out;
    // The content is 10 % brighter: the relative MAE the test would report, 0.1000.
    EXPECT_NE(out.find("relMAE 0.1000"), std::string::npos) << out;
    EXPECT_NE(err.find("--accept"), std::string::npos) << err;
    EXPECT_TRUE(fs::exists(p.actualFolder / "case_final_0.promote-diff.png"));
    EXPECT_EQ(readText(p.goldens / "case_final_0.png"), before) << "the golden changed without --accept";
    EXPECT_NE(readText(p.goldens / "case_final_0.json").find("old renderer"), std::string::npos);
}

TEST(PromoteGoldensTest, RefusesWithoutNamesOrWithAnUnknownName) {
    const Promotion p = makeCandidate("promote_names");
    const std::string before = readText(p.goldens / "case_final_0.png");
    EXPECT_EQ(promote(p, "--accept", "nonames"), 2);
    EXPECT_NE(readText(p.scratch / "nonames.err").find("name the goldens"), std::string::npos);
    EXPECT_EQ(promote(p, "--accept case_final_0 no_such_case", "unknown"), 1);
    EXPECT_NE(readText(p.scratch / "unknown.err").find("no_such_case"), std::string::npos);
    EXPECT_EQ(readText(p.goldens / "case_final_0.png"), before) << "nothing is promoted when one name is bad";
}

TEST(PromoteGoldensTest, AcceptCopiesTheNamedImageAndItsRendererSidecar) {
    const Promotion p = makeCandidate("promote_accept");
    EXPECT_EQ(promote(p, "--accept case_final_0", "accepted"), 0) << readText(p.scratch / "accepted.err");
    EXPECT_EQ(readText(p.goldens / "case_final_0.png"), readText(p.actualFolder / "case_final_0.actual.png"));
    EXPECT_NE(readText(p.goldens / "case_final_0.json").find("new renderer"), std::string::npos);
    EXPECT_NE(readText(p.scratch / "accepted.out").find("promoted case_final_0"), std::string::npos);
}

} // namespace
} // namespace lightskin::test
