// The technique registry's names (gi::toString, gi::parseTechnique) against themselves and against the lists
// the reference docs give: docs/SCENE_FORMAT.md's gi.technique and gi.backend rows (gi.backend lists the settings:
// auto and the backends) and docs/CLI.md's --backend and --backends options. A technique or backend added to the
// registry but not to the docs (or the other way round) fails here.
#include "TestPaths.h"

#include <lightskin/gi/common/Technique.h>

#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <set>
#include <string>

using namespace lightskin;

namespace {

std::set<std::string> registryTechniques() {
    std::set<std::string> names;
    for (const gi::Technique t : gi::kTechniques) names.insert(std::string(gi::toString(t)));
    return names;
}

std::set<std::string> registryBackends() {
    std::set<std::string> names;
    for (const gi::Backend b : gi::kBackends) names.insert(std::string(gi::toString(b)));
    return names;
}

std::set<std::string> registryBackendSettings() {
    std::set<std::string> names;
    for (const gi::BackendSetting s : gi::kBackendSettings) names.insert(std::string(gi::toString(s)));
    return names;
}

/// The first line of `file` that starts with `prefix`.
std::string lineStartingWith(const std::string& file, const std::string& prefix) {
    std::ifstream in(test::sourceDir() / file);
    EXPECT_TRUE(in) << file;
    for (std::string line; std::getline(in, line);)
        if (line.rfind(prefix, 0) == 0) return line;
    ADD_FAILURE() << file << " has no line starting with " << prefix;
    return {};
}

/// The `"name"` values in a Markdown table row's second column.
std::set<std::string> quotedValuesOfSecondColumn(const std::string& row) {
    const std::size_t first = row.find('|', 1);
    const std::size_t second = row.find('|', first + 1);
    const std::string column = row.substr(first + 1, second - first - 1);
    std::set<std::string> names;
    const std::regex quoted("`\"([a-z-]+)\"`");
    for (auto it = std::sregex_iterator(column.begin(), column.end(), quoted); it != std::sregex_iterator(); ++it)
        names.insert((*it)[1]);
    return names;
}

} // namespace

TEST(TechniqueNamesTest, EveryNameParsesBackToItsValue) {
    for (const gi::Technique t : gi::kTechniques) EXPECT_EQ(gi::parseTechnique(gi::toString(t)), t);
    for (const gi::Backend b : gi::kBackends) EXPECT_EQ(gi::parseBackend(gi::toString(b)), b);
    EXPECT_EQ(registryTechniques().size(), gi::kTechniques.size()); // one spelling per technique
    EXPECT_EQ(registryBackends().size(), gi::kBackends.size());
    // No other spelling: case, the bench's old "GL", the display name of the CPU backend.
    for (const char* other : {"LightSkin", "GL", "CPU", "lightskin-cpu", "bruteforce", ""}) {
        EXPECT_FALSE(gi::parseTechnique(other)) << other;
        EXPECT_FALSE(gi::parseBackend(other)) << other;
    }
    EXPECT_EQ(gi::techniqueNames(true),
              "\"lightskin\", \"brute-force\", \"imperfect-volumes\", \"multiscale-prt\" or \"none\"");
    EXPECT_EQ(gi::backendNames(false), "gl or cpu");
    // The settings: auto and every backend by its own spelling.
    for (const gi::BackendSetting b : gi::kBackendSettings) EXPECT_EQ(gi::parseBackendSetting(gi::toString(b)), b);
    for (const gi::Backend b : gi::kBackends)
        EXPECT_EQ(gi::toString(gi::settingOf(b)), gi::toString(b)) << gi::toString(b);
    EXPECT_EQ(registryBackendSettings().size(), gi::kBackendSettings.size());
    for (const char* other : {"Auto", "AUTO", "GL", "default", ""})
        EXPECT_FALSE(gi::parseBackendSetting(other)) << other;
    EXPECT_EQ(gi::backendSettingNames(true), "\"auto\", \"gl\" or \"cpu\"");
}

TEST(TechniqueNamesTest, OnlyLightSkinRunsOnTheCpu) {
    for (const gi::Technique t : gi::kTechniques) {
        EXPECT_TRUE(gi::runsOn(t, gi::Backend::Gl)) << gi::toString(t);
        EXPECT_EQ(gi::runsOn(t, gi::Backend::Cpu), t == gi::Technique::LightSkin) << gi::toString(t);
    }
}

TEST(TechniqueNamesTest, SceneFormatListsTheRegistry) {
    EXPECT_EQ(quotedValuesOfSecondColumn(lineStartingWith("docs/SCENE_FORMAT.md", "| `technique` |")),
              registryTechniques());
    EXPECT_EQ(quotedValuesOfSecondColumn(lineStartingWith("docs/SCENE_FORMAT.md", "| `backend` |")),
              registryBackendSettings());
}

TEST(TechniqueNamesTest, CliListsTheBackends) {
    // "--backends TEXT=gl,cpu": the sweep's default is every backend, in the registry's order.
    const std::string sweep = lineStartingWith("docs/CLI.md", "  --backends TEXT=");
    const std::string value = sweep.substr(sweep.find('=') + 1, sweep.find(' ', sweep.find('=')) - sweep.find('=') - 1);
    std::string expected;
    for (const gi::Backend b : gi::kBackends) expected += (expected.empty() ? "" : ",") + std::string(gi::toString(b));
    EXPECT_EQ(value, expected);
    // "--backend TEXT ... on gl or cpu ..., or auto ...": every backend setting named as a word.
    const std::string replay = lineStartingWith("docs/CLI.md", "  --backend TEXT");
    for (const gi::BackendSetting b : gi::kBackendSettings)
        EXPECT_TRUE(std::regex_search(replay, std::regex("\\b" + std::string(gi::toString(b)) + "\\b")))
            << gi::toString(b) << " missing from: " << replay;
}
