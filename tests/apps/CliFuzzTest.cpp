// No crash, no internal error, no raw library text on any command-line value: every option of every
// command (read from the program's own --help) gets 0, -1, nan, inf, 1e300, an empty value and text.
// The program runs with LIGHTSKIN_CHECK_ARGUMENTS_ONLY=1, which stops it once the command line is
// parsed and checked (main.cpp): that is where every value must be judged (docs/CLI.md: "everything
// is checked before anything is written"), and keeps the ~600 runs to process start-up (~0.3 s each; under
// AddressSanitizer 1.5-3 s, where each option gets three of the values: kValuesPerOption).
#include "CliRun.h"
#include "TestPaths.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <regex>
#include <set>
#include <sys/wait.h>

using namespace lightskin;
using namespace lightskin::test::cli;
namespace fs = std::filesystem;

namespace {

struct OptionSpec {
    std::string name; ///< "--repeat"
    std::string type; ///< "INT", "UINT", "FLOAT", "TEXT", "" for a flag
};

/// The commands `lightskin --help` lists, and whether each is a developer tool (the program
/// lightskin-tools, which `lightskin` runs with the same arguments).
std::vector<std::pair<std::string, bool>> commands(const fs::path& scratch) {
    const CliRun help = runCli("--help", scratch);
    std::vector<std::pair<std::string, bool>> names;
    bool inList = false, tools = false;
    std::istringstream lines(help.out);
    for (std::string line; std::getline(lines, line);) {
        if (line.empty() || line.back() == ':') {
            tools = line.find("Developer tools") != std::string::npos;
            inList = line.find("ubcommands") != std::string::npos || tools;
            continue;
        }
        std::smatch m;
        if (inList && std::regex_search(line, m, std::regex("^  ([a-z-]+) "))) names.emplace_back(m[1], tools);
    }
    return names;
}

/// The options of `command` from its --help: "  --name TYPE..." lines (flags have no type).
std::vector<OptionSpec> options(const std::string& command, const fs::path& scratch) {
    const CliRun help = runCli(command + " --help", scratch);
    std::vector<OptionSpec> specs;
    std::istringstream lines(help.out);
    const std::regex option("^  (?:-[a-z],)?(--[a-z0-9-]+)(?: ([A-Z]+))?");
    for (std::string line; std::getline(lines, line);) {
        std::smatch m;
        if (std::regex_search(line, m, option) && m[1] != "--help") specs.push_back({m[1], m[2]});
    }
    return specs;
}

/// Arguments that make the command line complete (required options and positionals), each a value the
/// parser accepts; the option under test comes after them.
std::string requiredArguments(const std::string& command) {
    static const std::map<std::string, std::string> required = {{"replay", "rec"},
                                                                {"live", "--scene s.json"},
                                                                {"record", "--source rec --out o"},
                                                                {"info", "rec"},
                                                                {"golden-diff", "a.png g.png"},
                                                                {"synth", "s.json --out o"},
                                                                {"track", "--tag-id 0 --tag-size 0.1 img.png"}};
    const auto found = required.find(command);
    return found == required.end() ? "" : found->second;
}

struct Outcome {
    int exitCode = -1;
    bool signalled = false;
    std::string err;
};

/// Runs `arguments` with LIGHTSKIN_CHECK_ARGUMENTS_ONLY=1: through lightskin-tools itself for a tool
/// (`lightskin` would stop before running it).
Outcome check(const std::string& arguments, bool tool, const fs::path& scratch) {
    const fs::path err = scratch / "stderr.txt";
    const std::string binary = tool ? (fs::path(program()).parent_path() / "lightskin-tools").string() : program();
    const int status = std::system(("cd " + scratch.string() + " && LIGHTSKIN_CHECK_ARGUMENTS_ONLY=1 " + binary + " " +
                                    arguments + " > /dev/null 2> " + err.string() + " < /dev/null")
                                       .c_str());
    Outcome o;
    o.signalled = status == -1 || !WIFEXITED(status) || WEXITSTATUS(status) > 128; // the shell reports 128+n
    o.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    o.err = test::readText(err);
    return o;
}

std::string quoted(const std::string& value) { return "'" + value + "'"; }

/// Every command of both programs, and whether it is a developer tool (lightskin-tools). One test per
/// command: under AddressSanitizer a run costs ~1 s of start-up, too long for ~600 runs in one test.
const std::vector<std::pair<std::string, bool>> kCommands = {
    {"doctor", false},      {"golden-diff", false},    {"info", false},        {"live", false},
    {"record", false},      {"replay", false},         {"track", false},       {"bench", true},
    {"bench-cpu", true},    {"bench-cull", true},      {"bench-embed", true},  {"bench-gather", true},
    {"bench-lights", true}, {"bench-realdepth", true}, {"bench-static", true}, {"synth", true}};

class CliFuzzCommand : public ::testing::TestWithParam<std::pair<std::string, bool>> {};

// Under AddressSanitizer a run costs 1.5-3 s of CPU, nearly all of it loading ~350 shared libraries (perf: the
// dynamic loader and the kernel's page faults, 80 %), not the checks. There each option gets three of the
// values, rotated by the option's position so that every value still reaches a share of the options (the
// memory checks see every kind of value); the normal build's suite gives every option every value.
#if defined(__SANITIZE_ADDRESS__)
constexpr std::size_t kValuesPerOption = 3;
#else
constexpr std::size_t kValuesPerOption = 1000;
#endif

} // namespace

TEST(CliFuzz, TheFuzzedCommandsAreThoseOfTheHelp) {
    const fs::path scratch = test::scratchDir("cli_fuzz_commands");
    EXPECT_EQ(commands(scratch), kCommands) << "a command was added or removed: update kCommands";
}

TEST_P(CliFuzzCommand, EveryOptionTakesBadValuesCleanly) {
    const auto& [command, tool] = GetParam();
    const fs::path scratch = test::scratchDir("cli_fuzz_" + command);
    // Text options get only the empty value and a word (what a number would be for them is text too).
    const std::vector<std::string> numbers = {"0", "-1", "nan", "inf", "1e300", "", "abc"}, words = {"", "abc"};
    // Refused by every numeric option: no count, size, time or rate is "not a number", text or empty.
    const std::set<std::string> neverANumber = {"nan", "", "abc", "1e300"};
    const std::vector<OptionSpec> specs = options(command, scratch);
    std::size_t runs = 0, valued = 0;
    for (const OptionSpec& spec : specs) {
        if (spec.type.empty()) continue; // a flag takes no value
        const bool numeric = spec.type == "INT" || spec.type == "UINT" || spec.type == "FLOAT";
        const std::vector<std::string>& values = numeric ? numbers : words;
        for (std::size_t k = 0; k < std::min(values.size(), kValuesPerOption); ++k) {
            const std::string& value = values[(valued + k) % values.size()];
            const std::string arguments =
                command + " " + requiredArguments(command) + " " + spec.name + " " + quoted(value);
            SCOPED_TRACE(arguments);
            const Outcome o = check(arguments, tool, scratch);
            ++runs;
            ASSERT_FALSE(o.signalled) << o.err;
            EXPECT_TRUE(o.exitCode == 0 || o.exitCode == 64) << o.exitCode << ": " << o.err;
            EXPECT_EQ(o.err.find("internal error"), std::string::npos) << o.err;
            EXPECT_EQ(o.err.find("exception"), std::string::npos) << o.err;
            if (numeric && neverANumber.count(value) > 0) {
                EXPECT_EQ(o.exitCode, 64) << "accepted: " << o.err;
            }
            if (o.exitCode == 64) {
                CliRun r;
                r.err = o.err;
                ASSERT_EQ(r.errLines().size(), 1u) << o.err;
                expectOneErrorLine(r, "error:");
                // The one line names the option (or, for "", that a value is missing).
                EXPECT_TRUE(o.err.find(spec.name) != std::string::npos || o.err.find("requires") != std::string::npos ||
                            o.err.find("argument") != std::string::npos)
                    << o.err;
            }
        }
        ++valued;
    }
    // Every command but info has options with values: none read means the --help format changed.
    if (command != "info") {
        EXPECT_GT(runs, 0u) << "no option with a value read from " << command << " --help";
    }
    std::printf("%s: %zu command lines checked\n", command.c_str(), runs);
}

INSTANTIATE_TEST_SUITE_P(EveryCommand, CliFuzzCommand, ::testing::ValuesIn(kCommands),
                         [](const ::testing::TestParamInfo<std::pair<std::string, bool>>& command) {
                             std::string name = command.param.first;
                             std::replace(name.begin(), name.end(), '-', '_');
                             return name;
                         });

// The concrete cases found by trying the program as a new user, run for real (no check-only mode):
// each is a usage error naming the option, never a crash or the C++ library's "stoi".
TEST(CliFuzz, TheReportedBadValuesAreUsageErrors) {
    const fs::path scratch = test::scratchDir("cli_fuzz_reported");
    for (const auto& [arguments, option] : std::vector<std::pair<std::string, std::string>>{
             {"bench-gather --repeat 0", "--repeat"},
             {"bench-gather --repeat -1", "--repeat"},
             {"bench-cull --vals abc", "--vals"},
             {"bench-cpu --threads abc", "--threads"},
             {"bench-realdepth --max-frames 0", "--max-frames"},
             {"bench --quick --sparse abc", "--sparse"},
             {"replay rec --budget-ms nan", "--budget-ms"},
             {"replay rec --budget-ms -5", "--budget-ms"},
             {"replay rec --write-frames 5-2", "--write-frames"},
             {"replay rec --write-frames ''", "--write-frames"},
             {"track --decimate 0 --tag-id 0 --tag-size 0.1 x.png", "--decimate"},
             {"track --fps 0 --tag-id 0 --tag-size 0.1 x.png", "--fps"},
             {"track --world w.json --tag-id 3 x.png", "--tag-id"},
         }) {
        SCOPED_TRACE(arguments);
        const CliRun r = runCli(arguments, scratch);
        EXPECT_EQ(r.exitCode, 64) << r.err;
        expectOneErrorLine(r, option);
        EXPECT_EQ(r.errLines().size(), 1u) << r.err;
    }
}
