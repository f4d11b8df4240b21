#pragma once
// What lightskin_bench_roommodel and lightskin_bench_roommodel_open3d share: per-frame statistics and the scene's
// roomModel block.
#include <lightskin/capture/DepthFilter.h>
#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>
#include <lightskin/core/RgbdFrame.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

namespace lightskin::bench {

struct FrameStats {
    std::vector<double> values;
    double median() {
        if (values.empty()) return -1.0;
        std::sort(values.begin(), values.end());
        return values[values.size() / 2];
    }
    double max() const { return values.empty() ? -1.0 : *std::max_element(values.begin(), values.end()); }
    double mean() const {
        double sum = 0.0;
        for (double v : values) sum += v;
        return values.empty() ? -1.0 : sum / double(values.size());
    }
};

/// The scene file's "roomModel" object as JSON text; throws lightskin::Error naming the file when it has none.
inline std::string roomModelBlock(const std::string& scenePath) {
    std::ifstream file(scenePath);
    if (!file) throw Error(scenePath, std::nullopt, "cannot open the scene file");
    const nlohmann::json scene = nlohmann::json::parse(file);
    if (!scene.contains("roomModel")) throw Error(scenePath, std::nullopt, "/roomModel: the scene has none");
    return scene["roomModel"].dump();
}

/// The benchmarks' command line: <recording> <scene|-> <lostFrom> <lostTo>, with their defaults.
struct RoomModelBenchArguments {
    std::string recording = "recordings/synth-orbit", scene = "recordings/scenes/orbit.json";
    int lostFrom = 10, lostTo = 30;
};
inline RoomModelBenchArguments roomModelBenchArguments(int argc, char** argv) {
    RoomModelBenchArguments a;
    if (argc > 1) a.recording = argv[1];
    if (argc > 2) a.scene = argv[2];
    if (argc > 3) a.lostFrom = std::atoi(argv[3]);
    if (argc > 4) a.lostTo = std::atoi(argv[4]);
    return a;
}

/// Every frame of `recording` (each must have a ground-truth pose) and its depth through the pipeline's bilateral
/// filter (mr/FramePipeline.cpp), CV_32FC1 metres.
inline void readFramesWithGroundTruth(const std::string& recording, std::vector<RgbdFrame>& frames,
                                      std::vector<cv::Mat>& depths) {
    auto source = capture::openFrameSource(recording);
    capture::BilateralDepthFilter filter;
    for (RgbdFrame frame; source->next(frame);) {
        if (!frame.groundTruth_world_T_camera) throw Error(recording, frame.index, "no ground-truth pose");
        frames.push_back(frame.clone());
        depths.emplace_back();
        filter.filterInto(frame.depth, frame.depthScaleMetres, depths.back());
    }
}

} // namespace lightskin::bench
