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

TEST(DetectorSettingsJsonTest, ErrorsNameTheSourceAndKey) {
    const auto errorOf = [](const std::string& text) {
        try {
            (void)tracking::detectorSettingsFromJson(text, "scene.json /tracking/detector");
        } catch (const Error& error) {
            EXPECT_EQ(error.source(), "scene.json /tracking/detector");
            return error.cause();
        }
        ADD_FAILURE() << "no error for " << text;
        return std::string();
    };
    EXPECT_NE(errorOf(R"({"quadDecimat": 1})").find("/quadDecimat: unknown"), std::string::npos);
    EXPECT_NE(errorOf(R"({"threads": 1.5})").find("/threads: expected an integer"), std::string::npos);
    EXPECT_NE(errorOf(R"({"refineEdges": "yes"})").find("/refineEdges: expected true or false"), std::string::npos);
    EXPECT_NE(errorOf(R"([1, 2])").find("JSON object"), std::string::npos);
    EXPECT_NE(errorOf(R"({"quadDecimate": )").find("malformed JSON"), std::string::npos);
}

} // namespace
} // namespace lightskin::test
