#pragma once
// The developer tools' commands (`synth`, `bench*`, in the program lightskin-tools) and their one-line
// descriptions: one table for both programs, so `lightskin --help` (which forwards them,
// ToolsForward.cpp) and `lightskin-tools --help` describe each command in the same words.
// A tool command takes its description from here (toolDescription); a new tool adds a row.

#include <lightskin/core/Error.h>

#include <array>
#include <string_view>

namespace lightskin::apps {

struct ToolCommand {
    std::string_view name;
    std::string_view description;
};

inline constexpr std::array<ToolCommand, 9> kToolCommands{{
    {"bench", "Sweep the LightSkin knobs: time and error against brute force and ground truth"},
    {"bench-cpu", "Time the CPU LightSkin backend beside the GL path (stages, interactions/s, % of peak)"},
    {"bench-cull", "Time the adaptive VAL cull: stable compaction against atomic append"},
    {"bench-embed",
     "Benchmark: session overheads for embedding hosts (render, GL state guard) and the frame budget's choices"},
    {"bench-gather", "Time the LightSkin stages and compare with the brute force"},
    {"bench-lights", "Time VAL generation, RSM VALs and sparse-point preparation"},
    {"bench-realdepth", "Speckle and flicker of the indirect light on real recordings, old vs robust light model"},
    {"bench-static",
     "Adaptive mode, static content: reuse vs full recomputation on still frames (exact, Kinect noise, real)"},
    {"synth", "Render a synthetic RGB-D recording with exact ground truth from a scene description"},
}};

/// The description of tool command `name`; a programmer error when the table has no row for it.
inline std::string toolDescription(std::string_view name) {
    for (const ToolCommand& command : kToolCommands)
        if (command.name == name) return std::string(command.description);
    LIGHTSKIN_ASSERT(false, "lightskin::apps::toolDescription(): a tool command without a row in kToolCommands");
    return {};
}

} // namespace lightskin::apps
