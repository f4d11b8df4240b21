#include <lightskin/core/Error.h>
#include <lightskin/tracking/TagDetector.h>

#include <gtest/gtest.h>

namespace lightskin::test {
namespace {

TEST(DetectorSettingsJsonTest, ReadsEveryKeyOverTheDefaults) {
    const tracking::DetectorSettings settings = tracking::detectorSettingsFromJson(
        R"({"family": "tag25h9", "quadDecimate": 1, "quadSigma": 0.8, "threads": 2, "refineEdges": false,
            "decodeSharpening": 0.5, "refineCorners": false, "maxHamming": 1, "minDecisionMargin": 30,
            "upsample": 2})",
        "scene /tracking/detector");
    EXPECT_EQ(settings.family, "tag25h9");
    EXPECT_EQ(settings.quadDecimate, 1.0f);
    EXPECT_EQ(settings.quadSigma, 0.8f);
    EXPECT_EQ(settings.threads, 2);
    EXPECT_FALSE(settings.refineEdges);
    EXPECT_EQ(settings.decodeSharpening, 0.5);
    EXPECT_FALSE(settings.refineCorners);
    EXPECT_EQ(settings.maxHamming, 1);
    EXPECT_EQ(settings.minDecisionMargin, 30.0f);
    EXPECT_EQ(settings.upsample, 2);
    // Keys not given keep the defaults.
    const tracking::DetectorSettings partial = tracking::detectorSettingsFromJson(R"({"quadDecimate": 1})", "x");
    EXPECT_EQ(partial.quadDecimate, 1.0f);
    EXPECT_EQ(partial.family, tracking::DetectorSettings{}.family);
    EXPECT_TRUE(partial.refineEdges);
    EXPECT_EQ(partial.upsample, 1);
}

// The scene file's format, "<file>: <JSON pointer>: expected ..., got ..." (render/src/Scene.cpp),
// for unknown keys, wrong types and values out of the library's range alike.
TEST(DetectorSettingsJsonTest, ErrorsNameTheFileKeyPathAndCauseLikeSceneErrors) {
    const auto errorOf = [](const std::string& text) {
        try {
            (void)tracking::detectorSettingsFromJson(text, "scene.json", "/tracking/detector");
        } catch (const Error& error) {
            EXPECT_EQ(error.source(), "scene.json");
            return std::string(error.what());
        }
        ADD_FAILURE() << "no error for " << text;
        return std::string();
    };
    EXPECT_EQ(errorOf(R"({"quadDecimate": -2})"),
              "scene.json: /tracking/detector/quadDecimate: expected a number in [1, 16], got -2");
    EXPECT_EQ(errorOf(R"({"quadDecimat": 1})"),
              "scene.json: /tracking/detector/quadDecimat: unknown key; expected one of: family, quadDecimate, "
              "quadSigma, threads, refineEdges, decodeSharpening, refineCorners, maxHamming, minDecisionMargin, "
              "upsample");
    EXPECT_EQ(errorOf(R"({"threads": 1.5})"), "scene.json: /tracking/detector/threads: expected an integer, got 1.5");
    EXPECT_EQ(errorOf(R"({"threads": 0})"),
              "scene.json: /tracking/detector/threads: expected an integer in [1, 64], got 0");
    // 2^32 + 1 would wrap to 1 in an int: refused by its value as written.
    EXPECT_EQ(errorOf(R"({"threads": 4294967297})").rfind("scene.json: /tracking/detector/threads: expected", 0), 0u);
    EXPECT_EQ(errorOf(R"({"refineEdges": "yes"})"),
              "scene.json: /tracking/detector/refineEdges: expected true or false, got \"yes\"");
    EXPECT_EQ(errorOf(R"({"upsample": 5})"),
              "scene.json: /tracking/detector/upsample: expected an integer in [1, 4], got 5");
    EXPECT_EQ(errorOf(R"({"family": "tag99"})").rfind("scene.json: /tracking/detector/family: expected one of: ", 0),
              0u);
    EXPECT_EQ(errorOf(R"([1, 2])").rfind("scene.json: /tracking/detector: expected an object", 0), 0u);
    EXPECT_EQ(errorOf(R"({"quadDecimate": )").rfind("scene.json: not valid JSON", 0), 0u);
}

// TagDetector::create checks the same ranges (a host that fills DetectorSettings in code), naming the key.
TEST(DetectorSettingsJsonTest, TheDetectorRefusesWhatTheReaderRefuses) {
    tracking::DetectorSettings settings;
    EXPECT_FALSE(tracking::findDetectorSettingProblem(settings).has_value());
    settings.quadDecimate = 0.5f;
    const auto problem = tracking::findDetectorSettingProblem(settings);
    ASSERT_TRUE(problem.has_value());
    EXPECT_EQ(problem->key, "quadDecimate");
    EXPECT_EQ(problem->cause, "expected a number in [1, 16], got 0.5");
    try {
        (void)tracking::TagDetector::create(settings);
        FAIL();
    } catch (const Error& error) {
        EXPECT_EQ(error.cause(), "/quadDecimate: expected a number in [1, 16], got 0.5");
    }
}

} // namespace
} // namespace lightskin::test
