// `lightskin track`: camera poses from AprilTags in a sequence of images, one line per frame.
//
//   lightskin track --world world.json [--intrinsics fx fy cx cy] [--decimate 2] [--upsample 1]
//                   [--threads 1] [--max-corner-std 3.4] [--no-filter] [--fps 30] image1.png image2.png ...
//   lightskin track --tag-id 0 --tag-size 0.16 images...
//   lightskin track --world recordings/synth-pan/synth/tag-world.json --decimate 1 recordings/synth-pan
//     (a recording: its intrinsics and timestamps; with ground truth, two more columns: errors)
//
// Output columns: frame, state, tags used, RMS reprojection error (px), world_T_camera as
// tx ty tz (metres) qw qx qy qz, rotation std (deg), world corner std (px: how well the pose places
// every tag of the world in the image, PoseUncertainty::worldCornerStdPx; also printed for a frame
// held because it exceeded --max-corner-std, "inf" without a measurement), ambiguous flag, total ms,
// reason. A last comment line counts the states and the frames whose measurement --max-corner-std
// refused (held, or lost before the first pose): "# frames N tracking T held H lost L; measurements
// refused as poorly determined P".
#include "CliSupport.h"
#include "Commands.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/tracking/PoseTracker.h>

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace lightskin::apps {

namespace {
struct TrackOptions {
    std::string worldPath;
    int tagId = -1;
    double tagSize = 0.0;
    std::string family = "tag36h11";
    std::vector<double> intrinsics;
    float decimate = 2.0f;
    int upsample = 1;
    int threads = 1;
    double maxCornerStd = tracking::TrackerSettings{}.maxWorldCornerStdPx;
    bool noFilter = false;
    double fps = 30.0;
    std::vector<std::string> images;
};

void runTrack(const TrackOptions& options, int& exitCode) {
    // The library checks these too, under their JSON names; here the message names the option.
    tracking::TrackerSettings settings;
    settings.detector.quadDecimate = options.decimate;
    settings.detector.upsample = options.upsample;
    settings.detector.threads = options.threads;
    if (options.worldPath.empty()) settings.detector.family = options.family;
    if (const auto problem = tracking::findDetectorSettingProblem(settings.detector)) {
        const std::string option = problem->key == "quadDecimate" ? "--decimate"
                                   : problem->key == "family"     ? "--family"
                                                                  : "--" + problem->key;
        throw Error(option, std::nullopt, problem->cause);
    }
    if (!(options.maxCornerStd > 0.0))
        throw Error("--max-corner-std", std::nullopt,
                    "must be > 0 pixels (inf switches the check off), got " + std::to_string(options.maxCornerStd));
    tracking::TagWorld world = [&] {
        if (!options.worldPath.empty()) return tracking::TagWorld::load(options.worldPath);
        if (options.tagId < 0 && options.tagSize == 0.0)
            throw Error("track", std::nullopt, "give --world <config.json> or --tag-id and --tag-size (metres)");
        if (options.tagId < 0) throw Error("--tag-id", std::nullopt, "expected a tag id >= 0 with --tag-size");
        if (!(options.tagSize > 0.0))
            throw Error(
                "--tag-size", std::nullopt,
                "expected the tag's black-border edge length in metres (> 0) with --tag-id, got " +
                    (options.tagSize == 0.0 ? std::string("none") : (std::ostringstream() << options.tagSize).str()));
        return tracking::TagWorld::singleTag(options.tagId, options.tagSize, options.family);
    }();
    // Every image is there before the first line is printed (a missing one is a bad command, not a lost frame).
    if (!(options.images.size() == 1 &&
          (std::filesystem::is_directory(options.images[0]) || options.images[0].ends_with(".oni"))))
        for (std::size_t i = 0; i < options.images.size(); ++i)
            if (!std::filesystem::is_regular_file(options.images[i]))
                throw Error(options.images[i], static_cast<std::int64_t>(i), "no such image file");
    settings.maxWorldCornerStdPx = options.maxCornerStd;
    settings.filter.enabled = !options.noFilter;
    tracking::PoseTracker tracker = tracking::PoseTracker::create(std::move(world), settings);

    std::printf("# frame state tags reprojection_px tx ty tz qw qx qy qz rotation_std_deg world_corner_std_px "
                "ambiguous total_ms "
                "[gt_position_error_m gt_rotation_error_deg] reason\n");
    tracking::TrackingResult result;
    int trackedFrames = 0, heldFrames = 0, poorlyDeterminedFrames = 0, lostFrames = 0, totalFrames = 0;
    const auto printResult = [&](std::int64_t index, const std::optional<Pose>& groundTruth) {
        std::string tags;
        for (const int id : result.tagsUsed) tags += (tags.empty() ? "" : ",") + std::to_string(id);
        if (tags.empty()) tags = "-";
        std::printf("%lld %s %s %.3f", static_cast<long long>(index), tracking::toString(result.state), tags.c_str(),
                    result.reprojectionErrorPx);
        if (result.world_T_camera) {
            const Pose& pose = *result.world_T_camera;
            std::printf(" %.5f %.5f %.5f %.6f %.6f %.6f %.6f", pose.translation().x, pose.translation().y,
                        pose.translation().z, pose.rotation().w, pose.rotation().x, pose.rotation().y,
                        pose.rotation().z);
        } else {
            std::printf(" - - - - - - -");
        }
        std::printf(" %.3f %.3f %d %.2f", result.uncertainty.rotationStdDegrees, result.uncertainty.worldCornerStdPx,
                    result.ambiguous ? 1 : 0, result.timing.totalMs);
        if (groundTruth) {
            if (result.world_T_camera)
                std::printf(" %.4f %.3f", Pose::translationDistance(*result.world_T_camera, *groundTruth),
                            Pose::rotationAngleBetween(*result.world_T_camera, *groundTruth) * 180.0 /
                                3.141592653589793);
            else
                std::printf(" - -");
        }
        std::string notes;
        for (const int id : result.unknownTags)
            notes += (notes.empty() ? " (ids not in the world: " : ",") + std::to_string(id);
        if (!notes.empty()) notes += ")";
        for (std::size_t k = 0; k < result.rejectedTags.size(); ++k)
            notes += (k == 0 ? " (dropped, disagreeing with the others: " : ",") +
                     std::to_string(result.rejectedTags[k]) + (k + 1 == result.rejectedTags.size() ? ")" : "");
        // The library names its setting; a user of this command knows it as --max-corner-std.
        std::string reason = result.reason[0] != '\0' ? result.reason : "-";
        if (const auto at = reason.find("maxWorldCornerStdPx"); at != std::string::npos)
            reason.replace(at, std::strlen("maxWorldCornerStdPx"), "--max-corner-std");
        std::printf(" %s%s\n", reason.c_str(), notes.c_str());
        ++totalFrames;
        trackedFrames += result.state == tracking::TrackingState::Tracking ? 1 : 0;
        heldFrames += result.state == tracking::TrackingState::Held ? 1 : 0;
        lostFrames += result.state == tracking::TrackingState::Lost ? 1 : 0;
        // Refused by maxWorldCornerStdPx (Held, or Lost before any pose): the uncertainty is the refused one's.
        poorlyDeterminedFrames += !result.measured_world_T_camera &&
                                          std::isfinite(result.uncertainty.worldCornerStdPx) &&
                                          result.uncertainty.worldCornerStdPx > settings.maxWorldCornerStdPx
                                      ? 1
                                      : 0;
    };
    const auto printSummary = [&] {
        std::printf("# frames %d tracking %d held %d lost %d; measurements refused as poorly determined %d\n",
                    totalFrames, trackedFrames, heldFrames, lostFrames, poorlyDeterminedFrames);
    };

    // One folder or .oni: a recording (intrinsics, timestamps and ground truth from the source).
    const bool isRecording = options.images.size() == 1 &&
                             (std::filesystem::is_directory(options.images[0]) || options.images[0].ends_with(".oni"));
    if (isRecording) {
        auto source = capture::openFrameSource(options.images[0]);
        RgbdFrame frame;
        while (source->next(frame)) {
            tracker.trackInto(frame, result);
            printResult(frame.index, frame.groundTruth_world_T_camera);
        }
        printSummary();
        exitCode = trackedFrames > 0 ? 0 : 1;
        return;
    }

    for (std::size_t i = 0; i < options.images.size(); ++i) {
        const std::string& path = options.images[i];
        const cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
        if (image.empty()) throw Error(path, static_cast<std::int64_t>(i), "cannot read the image");
        CameraIntrinsics intrinsics;
        if (options.intrinsics.size() == 4) {
            intrinsics.width = image.cols;
            intrinsics.height = image.rows;
            intrinsics.fx = options.intrinsics[0];
            intrinsics.fy = options.intrinsics[1];
            intrinsics.cx = options.intrinsics[2];
            intrinsics.cy = options.intrinsics[3];
        } else {
            if (i == 0)
                log::warning("track: no --intrinsics, using the Kinect v1 default (525/525) scaled to the image");
            intrinsics = CameraIntrinsics::kinectV1Default().scaledTo(image.cols, image.rows);
        }
        tracker.trackImageInto(image, intrinsics, static_cast<double>(i) / options.fps, static_cast<std::int64_t>(i),
                               result);
        printResult(static_cast<std::int64_t>(i), std::nullopt);
    }
    printSummary();
    exitCode = trackedFrames > 0 ? 0 : 1;
}

void addTrackCommand(CLI::App& app, int& exitCode) {
    auto* command =
        app.add_subcommand("track", "Camera poses from AprilTags in a sequence of images (one line per frame)");
    auto options = std::make_shared<TrackOptions>();
    auto* world =
        command->add_option("--world", options->worldPath, "Tag world config (JSON, see tracking/TagWorld.h)");
    auto* tagId = command->add_option("--tag-id", options->tagId, "Single tag id (instead of --world)")
                      ->check(CLI::Range(0, 1 << 20))
                      ->excludes(world);
    auto* tagSize = command->add_option("--tag-size", options->tagSize, "Single tag black-border edge length, metres")
                        ->check(finiteIn(1e-4, 100.0))
                        ->excludes(world)
                        ->needs(tagId);
    tagId->needs(tagSize);
    command->add_option("--family", options->family, "Tag family for --tag-id")->capture_default_str()->excludes(world);
    command->add_option("--intrinsics", options->intrinsics, "fx fy cx cy in pixels (no distortion)")
        ->expected(4)
        ->check(finiteIn(0.0, 1e6));
    command->add_option("--decimate", options->decimate, "quad_decimate (1 for small tags)")
        ->capture_default_str()
        ->check(finiteIn(1.0, 16.0));
    command
        ->add_option("--upsample", options->upsample,
                     "Detect on the image enlarged by this factor (1-4; 2 finds small tags, ~3.6x the time)")
        ->capture_default_str()
        ->check(CLI::Range(1, 4));
    command->add_option("--threads", options->threads, "Detector threads")
        ->capture_default_str()
        ->check(CLI::Range(1, 64));
    command
        ->add_option(
            "--max-corner-std", options->maxCornerStd,
            "Hold frames whose pose places the world's tag corners worse than this std, pixels (> 0; inf = off)")
        ->capture_default_str()
        ->check(CLI::Validator(
            [](std::string& text) -> std::string {
                if (text == "inf" || text == "infinity") return {};
                char* end = nullptr;
                const double value = std::strtod(text.c_str(), &end);
                if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(value) || !(value > 0.0) ||
                    value > 1e6)
                    return "expected a number of pixels in (0, 1e6], or inf, got '" + text + "'";
                return {};
            },
            ""));
    command->add_option("--fps", options->fps, "Frame rate the images were taken at")
        ->capture_default_str()
        ->check(finiteIn(0.01, 10000.0));
    command->add_flag("--no-filter", options->noFilter, "Report unfiltered poses");
    command->add_option("images", options->images, "Images in order, or one recording folder / .oni file")->required();
    command->callback([options, &exitCode] { runTrack(*options, exitCode); });
}
} // namespace

static const CommandRegistration registration{"track", &addTrackCommand};

} // namespace lightskin::apps
