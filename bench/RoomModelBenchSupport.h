#pragma once
// What lightskin_bench_roommodel and lightskin_bench_roommodel_open3d share: per-frame statistics and the scene's
// roomModel block.
#include <lightskin/core/Error.h>

#include <nlohmann/json.hpp>

#include <algorithm>
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

} // namespace lightskin::bench
