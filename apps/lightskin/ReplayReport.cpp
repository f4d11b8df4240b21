#include "ReplayReport.h"

#include <lightskin/core/Error.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>

namespace lightskin::apps {

namespace {

nlohmann::json poseJson(const Pose& pose) {
    const glm::dquat& q = pose.rotation();
    const glm::dvec3& t = pose.translation();
    return {{"rotationXYZW", {q.x, q.y, q.z, q.w}}, {"translation", {t.x, t.y, t.z}}};
}

std::string fixed(double value, int decimals) {
    char text[64];
    std::snprintf(text, sizeof text, "%.*f", decimals, value);
    return text;
}

std::string escapeCell(std::string text) {
    for (std::size_t i = 0; (i = text.find('|', i)) != std::string::npos; i += 2) text.insert(i, "\\");
    return text;
}

void writeFile(const std::filesystem::path& path, const std::string& text) {
    std::ofstream file(path, std::ios::binary);
    file << text;
    if (!file) throw Error(path.string(), std::nullopt, "could not write the report");
}

} // namespace

nlohmann::json lightEstimateJson(const roomlight::LightEstimate& estimate, bool fitted,
                                 const mr::EstimatedDirectLight& direct, double cpuMs) {
    const auto vec = [](const auto& v) { return nlohmann::json::array({double(v.x), double(v.y), double(v.z)}); };
    nlohmann::json sh = nlohmann::json::array();
    for (const glm::dvec3& k : estimate.sh) sh.push_back(vec(k));
    const roomlight::DominantLight& d = estimate.dominant;
    nlohmann::json emitters = nlohmann::json::array();
    for (int i = 0; i < estimate.emitterCount; ++i) {
        const roomlight::AreaEmitter& e = estimate.emitters[std::size_t(i)];
        emitters.push_back({{"positionWorld", vec(e.positionWorld)},
                            {"normalWorld", vec(e.normalWorld)},
                            {"areaSquareMetres", e.areaSquareMetres},
                            {"radiance", vec(e.radiance)}});
    }
    return {{"sh", sh},
            {"dominant",
             {{"directionWorld", vec(d.directionWorld)},
              {"positionWorld", d.positionWorld ? vec(*d.positionWorld) : nlohmann::json(nullptr)},
              {"colour", vec(d.colour)},
              {"intensity", d.intensity},
              {"source", roomlight::toString(d.source)}}},
            {"emitters", emitters},
            {"residual", estimate.residual},
            {"state", roomlight::toString(estimate.state)},
            {"problem", roomlight::toString(estimate.problem)},
            {"referencePointWorld", vec(estimate.referencePointWorld)},
            {"exposureGain", vec(estimate.exposureGain)},
            {"samplesFitted", estimate.samplesFitted},
            {"fittedThisFrame", fitted},
            {"cpuMs", cpuMs},
            {"direct",
             {{"use", mr::toString(direct.use)},
              {"positionWorld", vec(direct.positionWorld)},
              {"powerWatts", vec(direct.power)},
              {"distanceMetres", direct.distanceMetres}}}};
}

void writeReplayReport(const std::filesystem::path& folder, const ReportSummary& s,
                       const std::vector<ReportFrame>& frames) {
    // Stage names in first-seen order, and their means.
    std::vector<std::string> cpuStages, gpuStages;
    std::map<std::string, double> cpuSum, gpuSum;
    std::map<std::string, int> trackingCounts;
    for (const ReportFrame& f : frames) {
        for (const auto& st : f.cpuTimes) {
            if (std::find(cpuStages.begin(), cpuStages.end(), st.name) == cpuStages.end()) cpuStages.push_back(st.name);
            cpuSum[st.name] += st.milliseconds;
        }
        for (const auto& st : f.gpuTimes) {
            if (std::find(gpuStages.begin(), gpuStages.end(), st.name) == gpuStages.end()) gpuStages.push_back(st.name);
            gpuSum[st.name] += st.milliseconds;
        }
        ++trackingCounts[f.trackingState];
    }
    double totalSum = 0.0;
    for (const ReportFrame& f : frames) totalSum += f.totalMs;
    // GI inactive frames by cause, in first-seen order.
    std::int64_t giActiveFrames = 0;
    std::vector<std::pair<std::string, std::int64_t>> giInactive;
    for (const ReportFrame& f : frames) {
        if (f.giActive) {
            ++giActiveFrames;
            continue;
        }
        auto it = std::find_if(giInactive.begin(), giInactive.end(),
                               [&](const auto& c) { return c.first == f.giInactiveCause; });
        if (it == giInactive.end())
            giInactive.emplace_back(f.giInactiveCause, 1);
        else
            ++it->second;
    }
    // Pose error against ground truth: mean, median and max over the frames that have both.
    std::vector<double> poseMetres, poseDegrees;
    for (const ReportFrame& f : frames)
        if (f.poseErrorMetres >= 0.0) {
            poseMetres.push_back(f.poseErrorMetres);
            poseDegrees.push_back(f.poseErrorDegrees);
        }
    const auto statistics = [](std::vector<double> values) {
        nlohmann::json j;
        if (values.empty()) return j;
        std::sort(values.begin(), values.end());
        double sum = 0.0;
        for (double v : values) sum += v;
        j["mean"] = sum / double(values.size());
        j["median"] = values[values.size() / 2];
        j["max"] = values.back();
        return j;
    };
    const nlohmann::json poseMetresStats = statistics(poseMetres), poseDegreesStats = statistics(poseDegrees);
    // The same per tracking state: a held pose (the last good one while the tags are poorly seen)
    // is expected to drift from the truth; tracking frames measure the tracker.
    std::map<std::string, std::pair<std::vector<double>, std::vector<double>>> poseByState;
    for (const ReportFrame& f : frames)
        if (f.poseErrorMetres >= 0.0) {
            poseByState[f.trackingState].first.push_back(f.poseErrorMetres);
            poseByState[f.trackingState].second.push_back(f.poseErrorDegrees);
        }
    std::string giSummary = std::to_string(giActiveFrames) + " of " + std::to_string(frames.size()) + " frames";
    for (const auto& [cause, count] : giInactive)
        giSummary += "; **inactive in " + std::to_string(count) + "**: " + cause;
    const double n = std::max<double>(1.0, double(frames.size()));

    nlohmann::json root;
    root["recording"] = s.recording;
    root["scene"] = s.scene;
    root["renderer"] = s.renderer;
    root["technique"] = s.technique;
    root["giBackend"] = s.giBackend;
    root["giBackendReason"] = s.giBackendReason;
    root["poseMode"] = s.poseMode;
    if (!s.compareLeft.empty()) root["compareLabels"] = {s.compareLeft, s.compareRight};
    root["command"] = s.command;
    root["framesRead"] = s.framesRead;
    root["framesInSource"] = s.framesInSource ? nlohmann::json(*s.framesInSource) : nlohmann::json(nullptr);
    root["interrupted"] = s.interrupted;
    root["status"] = !s.failure.empty() ? "failed" : s.interrupted ? "interrupted" : "complete";
    root["failure"] = s.failure.empty() ? nlohmann::json(nullptr) : nlohmann::json(s.failure);
    root["wallSeconds"] = s.wallSeconds;
    root["steadyMsPerFrame"] = s.steadyMsPerFrame;
    root["video"] = s.video;
    root["videoCodec"] = s.videoCodec;
    root["meanFrameMs"] = totalSum / n;
    if (s.prtPrepare) {
        const gi::PrtPrepareStats& p = *s.prtPrepare;
        root["precompute"] = {
            {"technique", "multiscale-prt"},
            {"loadedFromCache", p.loadedFromCache},
            {"prepareMs", p.prepareSeconds * 1e3},
            {"precomputeMs", p.precomputeSeconds * 1e3},
            {"memoryBytes", p.memoryBytes},
            {"cacheFileBytes", p.cacheFileBytes},
            {"cacheFile", p.cacheFile.empty() ? nlohmann::json(nullptr) : nlohmann::json(p.cacheFile.string())}};
    }
    if (!poseMetres.empty()) {
        root["poseError"] = {{"frames", poseMetres.size()},
                             {"framesWithoutPose", std::int64_t(frames.size()) - std::int64_t(poseMetres.size())},
                             {"translationMetres", poseMetresStats},
                             {"rotationDegrees", poseDegreesStats}};
        for (const auto& [state, errors] : poseByState)
            root["poseError"]["byState"][state] = {{"frames", errors.first.size()},
                                                   {"translationMetres", statistics(errors.first)},
                                                   {"rotationDegrees", statistics(errors.second)}};
    }
    root["giActiveFrames"] = giActiveFrames;
    root["giInactiveFrames"] = std::int64_t(frames.size()) - giActiveFrames;
    root["giInactiveCauses"] = nlohmann::json::object();
    for (const auto& [cause, count] : giInactive) root["giInactiveCauses"][cause] = count;
    {
        std::int64_t adaptive = 0, reused = 0;
        for (const ReportFrame& f : frames)
            if (f.giReused >= 0) {
                ++adaptive;
                reused += f.giReused;
            }
        if (adaptive > 0) root["giReusedFrames"] = reused;
        std::int64_t nanPixels = 0, infPixels = 0;
        for (const ReportFrame& f : frames) {
            nanPixels += f.linearNanPixels;
            infPixels += f.linearInfPixels;
        }
        root["linearNanPixels"] = nanPixels;
        root["linearInfPixels"] = infPixels;
    }
    for (const auto& name : cpuStages) root["meanCpuMs"][name] = cpuSum[name] / n;
    for (const auto& name : gpuStages) root["meanGpuMs"][name] = gpuSum[name] / n;
    for (const auto& [state, count] : trackingCounts) root["trackingStates"][state] = count;
    root["frames"] = nlohmann::json::array();
    for (const ReportFrame& f : frames) {
        nlohmann::json j;
        j["index"] = f.index;
        j["tracking"] = f.trackingState;
        if (!f.trackingReason.empty()) j["trackingReason"] = f.trackingReason;
        j["world_T_camera"] = f.world_T_camera ? poseJson(*f.world_T_camera) : nlohmann::json(nullptr);
        if (f.poseErrorMetres >= 0.0)
            j["poseError"] = {{"translationMetres", f.poseErrorMetres}, {"rotationDegrees", f.poseErrorDegrees}};
        j["vals"] = f.valCount;
        j["giActive"] = f.giActive;
        if (!f.giActive) j["giInactiveCause"] = f.giInactiveCause;
        if (f.rsmValCount >= 0) j["rsmVals"] = f.rsmValCount;
        if (f.valsDropped >= 0) j["valsDropped"] = f.valsDropped;
        j["totalMs"] = f.totalMs;
        if (f.errorVsBruteForce >= 0.0) j["meanRelativeErrorVsBruteForce"] = f.errorVsBruteForce;
        if (f.vplSegments >= 0) j["vplSegments"] = f.vplSegments;
        if (f.vplNonFinite >= 0) j["vplNonFinite"] = f.vplNonFinite;
        if (f.giReused >= 0) j["giReused"] = f.giReused == 1;
        if (f.giChangeMeasure >= 0.0f) j["giChangeMeasure"] = f.giChangeMeasure;
        if (f.volumeVoxelsDropped >= 0) j["volumeVoxelsDropped"] = f.volumeVoxelsDropped;
        if (!f.giSettings.empty()) j["giSettings"] = f.giSettings;
        if (f.predictedMs >= 0.0) j["budgetPredictedMs"] = f.predictedMs;
        if (f.lightEstimate)
            j["lightEstimate"] =
                lightEstimateJson(*f.lightEstimate, f.roomLightFitted, f.estimatedLight, f.roomLightCpuMs);
        for (const auto& st : f.cpuTimes) j["cpuMs"][st.name] = st.milliseconds;
        for (const auto& st : f.gpuTimes) {
            const bool seen = j.contains("gpuMs") && j["gpuMs"].contains(st.name);
            j["gpuMs"][st.name] = (seen ? j["gpuMs"][st.name].get<double>() : 0.0) + st.milliseconds;
        }
        const auto presentJson = [](const ReportFrame::PresentError& e) {
            return nlohmann::json{{"pixels", e.pixels},
                                  {"withDifferential", {{"mae", e.maeWith}, {"rmse", e.rmseWith}}},
                                  {"withoutDifferential", {{"mae", e.maeWithout}, {"rmse", e.rmseWithout}}}};
        };
        if (f.present.pixels >= 0)
            j["objectsPresentError"] = {{"affected", presentJson(f.present)}, {"real", presentJson(f.presentReal)}};
        if (!f.presentImage.empty()) j["presentImage"] = f.presentImage;
        j["linearNanPixels"] = f.linearNanPixels;
        j["linearInfPixels"] = f.linearInfPixels;
        if (!f.linearImage.empty()) j["linearImage"] = f.linearImage;
        if (!f.linearIndirectImage.empty()) j["linearIndirectImage"] = f.linearIndirectImage;
        if (!f.image.empty()) j["image"] = f.image;
        if (!f.compareImage.empty()) j["compareImage"] = f.compareImage;
        root["frames"].push_back(std::move(j));
    }
    writeFile(folder / "report.json", root.dump(2) + "\n");

    std::string md;
    md += "# lightskin replay report\n\n";
    if (!s.failure.empty())
        md += "**FAILED** after " + std::to_string(s.framesRead) + " frames: " + escapeCell(s.failure) +
              "\n\nThe frames, images and video below are what was written before the failure.\n\n";
    md += "| | |\n|---|---|\n";
    md += "| recording | `" + s.recording + "` |\n";
    md += "| scene | `" + s.scene + "` |\n";
    md += "| command | `" + s.command + "` |\n";
    md += "| renderer | " + escapeCell(s.renderer) + " |\n";
    md += "| GI technique | " + s.technique + " |\n";
    md += "| GI backend | " + s.giBackend + ": " + escapeCell(s.giBackendReason) + " |\n";
    md += "| GI active | " + giSummary + " |\n";
    md += "| pose | " + s.poseMode + " |\n";
    md += "| frames read | " + std::to_string(s.framesRead) +
          (s.framesInSource ? " of " + std::to_string(*s.framesInSource) : std::string()) +
          (s.interrupted ? " (interrupted)" : "") + " |\n";
    md += "| wall time | " + fixed(s.wallSeconds, 1) + " s" + " (" +
          fixed(s.wallSeconds > 0 ? double(s.framesRead) / s.wallSeconds : 0.0, 2) + " frames/s) |\n";
    if (s.steadyMsPerFrame > 0.0)
        md += "| after the first frame | " + fixed(s.steadyMsPerFrame, 1) + " ms per frame (" +
              fixed(1000.0 / s.steadyMsPerFrame, 2) + " frames/s) |\n";
    md += "| video | " + (s.video.empty() ? std::string("none") : "`" + s.video + "` (" + s.videoCodec + ")") + " |\n";
    std::string states;
    for (const auto& [state, count] : trackingCounts)
        states += (states.empty() ? "" : ", ") + state + " " + std::to_string(count);
    md += "| tracking states | " + states + " |\n";
    if (!poseMetres.empty())
        md += "| pose error vs ground truth | translation mean " + fixed(poseMetresStats["mean"].get<double>(), 3) +
              " m, median " + fixed(poseMetresStats["median"].get<double>(), 3) + " m, max " +
              fixed(poseMetresStats["max"].get<double>(), 3) + " m; rotation mean " +
              fixed(poseDegreesStats["mean"].get<double>(), 2) + " deg, median " +
              fixed(poseDegreesStats["median"].get<double>(), 2) + " deg, max " +
              fixed(poseDegreesStats["max"].get<double>(), 2) + " deg (" + std::to_string(poseMetres.size()) +
              " frames with a pose; " + std::to_string(frames.size() - poseMetres.size()) + " without) |\n";
    if (poseByState.size() > 1 || (poseByState.size() == 1 && poseByState.begin()->first != "tracking"))
        for (const auto& [state, errors] : poseByState) {
            const nlohmann::json m = statistics(errors.first), d = statistics(errors.second);
            md += "| pose error, " + state + " frames | translation mean " + fixed(m["mean"].get<double>(), 3) +
                  " m, max " + fixed(m["max"].get<double>(), 3) + " m; rotation mean " +
                  fixed(d["mean"].get<double>(), 2) + " deg, max " + fixed(d["max"].get<double>(), 2) + " deg (" +
                  std::to_string(errors.first.size()) + " frames) |\n";
        }
    {
        std::int64_t nanPixels = 0, infPixels = 0, badFrames = 0;
        for (const ReportFrame& f : frames) {
            nanPixels += f.linearNanPixels;
            infPixels += f.linearInfPixels;
            badFrames += f.linearNanPixels + f.linearInfPixels > 0 ? 1 : 0;
        }
        md += "| non-finite linear pixels | " + std::to_string(nanPixels) + " NaN, " + std::to_string(infPixels) +
              " inf (" + std::to_string(badFrames) + " frames) |\n";
    }
    std::size_t adaptiveFrames = 0, reusedFrames = 0;
    for (const ReportFrame& f : frames)
        if (f.giReused >= 0) {
            ++adaptiveFrames;
            if (f.giReused == 1) ++reusedFrames;
        }
    if (adaptiveFrames > 0)
        md += "| static-content reuse (adaptive) | " + std::to_string(reusedFrames) + " of " +
              std::to_string(adaptiveFrames) + " frames reused the VPLs |\n";
    std::int64_t bounceFrames = 0, rsmVals = 0, dropped = 0;
    for (const ReportFrame& f : frames)
        if (f.rsmValCount >= 0) {
            ++bounceFrames;
            rsmVals += f.rsmValCount;
            dropped += std::max<std::int64_t>(0, f.valsDropped);
        }
    if (bounceFrames > 0)
        md += "| virtual bounce (RSM) | " + fixed(double(rsmVals) / double(bounceFrames), 0) +
              " RSM VALs per frame (mean of " + std::to_string(bounceFrames) + " frames), " + std::to_string(dropped) +
              " VALs dropped in all" + (dropped > 0 ? " (merged set full!)" : "") + " |\n";
    for (const bool realOnly : {false, true}) {
        std::int64_t presentFrames = 0, pixels = 0;
        double maeWith = 0.0, maeWithout = 0.0, rmseWith = 0.0, rmseWithout = 0.0;
        for (const ReportFrame& f : frames) {
            const ReportFrame::PresentError& e = realOnly ? f.presentReal : f.present;
            if (e.pixels < 0) continue;
            ++presentFrames;
            pixels += e.pixels;
            maeWith += e.maeWith;
            maeWithout += e.maeWithout;
            rmseWith += e.rmseWith;
            rmseWithout += e.rmseWithout;
        }
        if (presentFrames == 0) continue;
        const double k = double(presentFrames);
        md += std::string("| error vs objects really there (synth/present, linear, ") +
              (realOnly ? "affected real pixels" : "all affected pixels") + ") | with differential: MAE " +
              fixed(maeWith / k, 5) + ", RMSE " + fixed(rmseWith / k, 5) + "; without: MAE " +
              fixed(maeWithout / k, 5) + ", RMSE " + fixed(rmseWithout / k, 5) + " (mean of " +
              std::to_string(presentFrames) + " frames, " + fixed(double(pixels) / k, 0) + " pixels per frame) |\n";
    }
    if (s.prtPrepare) {
        const gi::PrtPrepareStats& p = *s.prtPrepare;
        md += "| multi-scale PRT precompute | " +
              (p.loadedFromCache ? "loaded from the cache"
                                 : "computed in " + fixed(p.precomputeSeconds * 1e3, 1) + " ms") +
              "; prepare() " + fixed(p.prepareSeconds * 1e3, 1) + " ms; transfer in memory " +
              fixed(double(p.memoryBytes) / 1024.0, 0) + " KiB; cache file " +
              (p.cacheFile.empty()
                   ? std::string("none")
                   : "`" + p.cacheFile.string() + "` (" + fixed(double(p.cacheFileBytes) / 1024.0, 0) + " KiB)") +
              " |\n";
    }
    md += "\n";

    md += "## Mean stage times\n\n| stage | kind | ms |\n|---|---|---|\n";
    // Once, before the first frame (not in the frames' total): the cost the per-frame rows amortise.
    if (s.prtPrepare)
        md += std::string("| multi-scale PRT prepare (once; ") +
              (s.prtPrepare->loadedFromCache ? "cache load" : "precompute") + ") | CPU wall | " +
              fixed(s.prtPrepare->prepareSeconds * 1e3, 2) + " |\n";
    for (const auto& name : cpuStages) md += "| " + name + " | CPU wall | " + fixed(cpuSum[name] / n, 2) + " |\n";
    for (const auto& name : gpuStages) md += "| " + name + " | GPU | " + fixed(gpuSum[name] / n, 2) + " |\n";
    md += "| total | CPU wall | " + fixed(totalSum / n, 2) + " |\n\n";

    md += "## " + s.compareTitle + "\n\n";
    int shown = 0;
    for (const ReportFrame& f : frames) {
        if (f.compareImage.empty() && f.image.empty()) continue;
        if (++shown > 8) break;
        const std::string& image = f.compareImage.empty() ? f.image : f.compareImage;
        md += "Frame " + std::to_string(f.index) + " (" + f.trackingState + ")\n\n![frame " + std::to_string(f.index) +
              "](" + image + ")\n\n";
    }
    if (shown == 0) md += "No images were written (see `--frames`).\n\n";

    md += "## Per frame: tracking, pose track (world_T_camera translation, metres) and stage times (ms)\n\n";
    md += std::string("| frame | tracking | x | y | z |") +
          (poseMetres.empty() ? "" : " pose error m | pose error deg |") + " VALs | GI |" +
          (bounceFrames > 0 ? " RSM VALs |" : "");
    for (const auto& name : cpuStages) md += " " + name + " |";
    for (const auto& name : gpuStages) md += " GPU " + name + " |";
    md += std::string(" total |\n|---|---|---|---|---|---|---|") + (poseMetres.empty() ? "" : "---|---|") +
          (bounceFrames > 0 ? "---|" : "");
    for (std::size_t i = 0; i < cpuStages.size() + gpuStages.size() + 1; ++i) md += "---|";
    md += "\n";
    for (const ReportFrame& f : frames) {
        md += "| " + std::to_string(f.index) + " | " + f.trackingState + " | ";
        if (f.world_T_camera) {
            const glm::dvec3 t = f.world_T_camera->translation();
            md += fixed(t.x, 3) + " | " + fixed(t.y, 3) + " | " + fixed(t.z, 3) + " | ";
        } else {
            md += "- | - | - | ";
        }
        if (!poseMetres.empty())
            md += f.poseErrorMetres >= 0.0 ? fixed(f.poseErrorMetres, 3) + " | " + fixed(f.poseErrorDegrees, 2) + " | "
                                           : std::string("- | - | ");
        md += std::to_string(f.valCount) + " | " +
              (f.giActive ? std::string("active") : "inactive: " + escapeCell(f.giInactiveCause)) + " |";
        if (bounceFrames > 0)
            md += " " + (f.rsmValCount >= 0 ? std::to_string(f.rsmValCount) : std::string("-")) + " |";
        for (const auto& name : cpuStages) {
            double v = NAN;
            for (const auto& st : f.cpuTimes)
                if (st.name == name) v = st.milliseconds;
            md += " " + (std::isnan(v) ? std::string("-") : fixed(v, 2)) + " |";
        }
        for (const auto& name : gpuStages) {
            double v = 0.0;
            bool seen = false;
            for (const auto& st : f.gpuTimes)
                if (st.name == name) {
                    v += st.milliseconds;
                    seen = true;
                }
            md += " " + (seen ? fixed(v, 2) : std::string("-")) + " |";
        }
        md += " " + fixed(f.totalMs, 2) + " |\n";
    }
    writeFile(folder / "report.md", md);
}

} // namespace lightskin::apps
