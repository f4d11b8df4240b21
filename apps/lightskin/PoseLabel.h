#pragma once
// What placed the virtual content in a frame, as replay's report and live's status line name it.
// Only a tracked pose is "tracking"; a ground-truth or fixed pose says so (the pipeline marks those
// frames TrackingState::Tracking because a pose is present).

#include <lightskin/mr/FramePipeline.h>

#include <string>

namespace lightskin::apps {

inline std::string poseLabel(mr::PoseMode mode, const tracking::TrackingResult& result) {
    switch (mode) {
    case mr::PoseMode::Tracking:
        return tracking::toString(result.state);
    case mr::PoseMode::GroundTruth:
        return result.world_T_camera ? "ground-truth" : "no ground truth";
    case mr::PoseMode::Fixed:
        return "fixed";
    }
    return tracking::toString(result.state);
}

} // namespace lightskin::apps
