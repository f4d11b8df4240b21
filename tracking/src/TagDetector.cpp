#include <lightskin/tracking/TagDetector.h>

#include "Families.h"

#include <lightskin/core/Error.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>

namespace lightskin::tracking {

namespace {
struct DetectorDeleter {
    void operator()(apriltag_detector_t* detector) const noexcept { apriltag_detector_destroy(detector); }
};
struct DetectionsDeleter {
    void operator()(zarray_t* detections) const noexcept { apriltag_detections_destroy(detections); }
};
} // namespace

struct TagDetector::Impl {
    DetectorSettings settings;
    // Destruction order matters: the detector refers to the family, so it is declared after it
    // (destroyed first).
    detail::FamilyPtr family;
    std::unique_ptr<apriltag_detector_t, DetectorDeleter> detector;
    cv::Mat grey; // conversion buffer, reused
};

TagDetector TagDetector::create(const DetectorSettings& settings) {
    if (!(settings.quadDecimate >= 1.0f && settings.quadDecimate <= 16.0f))
        throw Error("quad_decimate", std::nullopt, "must be in [1, 16], got " + std::to_string(settings.quadDecimate));
    if (!(settings.quadSigma >= 0.0f && settings.quadSigma <= 10.0f))
        throw Error("quad_sigma", std::nullopt, "must be in [0, 10], got " + std::to_string(settings.quadSigma));
    if (settings.threads < 1 || settings.threads > 64)
        throw Error("nthreads", std::nullopt, "must be in [1, 64], got " + std::to_string(settings.threads));
    if (!(settings.decodeSharpening >= 0.0 && settings.decodeSharpening <= 10.0))
        throw Error("decode_sharpening", std::nullopt,
                    "must be in [0, 10], got " + std::to_string(settings.decodeSharpening));
    if (settings.maxHamming < 0 || settings.maxHamming > 2)
        throw Error("max_hamming", std::nullopt, "must be 0, 1 or 2, got " + std::to_string(settings.maxHamming));

    auto impl = std::make_unique<Impl>();
    impl->settings = settings;
    impl->family = detail::createFamily(settings.family);
    impl->detector.reset(apriltag_detector_create());
    if (!impl->detector) throw Error(settings.family, std::nullopt, "apriltag_detector_create failed");
    // The library's decode table holds every code within `bits_corrected` errors: asking for no
    // more than we accept saves memory (tag36h11 with 2 bits is tens of MB) and start-up time.
    apriltag_detector_add_family_bits(impl->detector.get(), impl->family.get(), settings.maxHamming);
    impl->detector->quad_decimate = settings.quadDecimate;
    impl->detector->quad_sigma = settings.quadSigma;
    impl->detector->nthreads = settings.threads;
    impl->detector->refine_edges = settings.refineEdges;
    impl->detector->decode_sharpening = settings.decodeSharpening;
    return TagDetector(std::move(impl));
}

TagDetector::TagDetector(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
TagDetector::TagDetector(TagDetector&&) noexcept = default;
TagDetector& TagDetector::operator=(TagDetector&&) noexcept = default;
TagDetector::~TagDetector() = default;

const DetectorSettings& TagDetector::settings() const noexcept { return impl_->settings; }

int TagDetector::detectInto(const cv::Mat& image, std::vector<TagDetection>& out) {
    LIGHTSKIN_ASSERT(impl_ != nullptr, "detector was moved from");
    LIGHTSKIN_ASSERT(image.depth() == CV_8U && (image.channels() == 1 || image.channels() == 3 || image.channels() == 4),
                     "expects an 8-bit grey, BGR or BGRA image");
    out.clear();
    if (image.empty()) return 0;
    const cv::Mat* grey = &image;
    if (image.channels() == 3) {
        cv::cvtColor(image, impl_->grey, cv::COLOR_BGR2GRAY);
        grey = &impl_->grey;
    } else if (image.channels() == 4) {
        cv::cvtColor(image, impl_->grey, cv::COLOR_BGRA2GRAY);
        grey = &impl_->grey;
    }
    // The library only reads the pixels; image_u8_t has no const variant.
    image_u8_t view{grey->cols, grey->rows, static_cast<std::int32_t>(grey->step[0]), const_cast<std::uint8_t*>(grey->data)};
    const std::unique_ptr<zarray_t, DetectionsDeleter> detections(apriltag_detector_detect(impl_->detector.get(), &view));
    const int count = zarray_size(detections.get());
    for (int i = 0; i < count; ++i) {
        apriltag_detection_t* raw = nullptr;
        zarray_get(detections.get(), i, &raw);
        if (raw->hamming > impl_->settings.maxHamming || raw->decision_margin < impl_->settings.minDecisionMargin) continue;
        TagDetection& detection = out.emplace_back();
        detection.id = raw->id;
        detection.hamming = raw->hamming;
        detection.decisionMargin = raw->decision_margin;
        for (std::size_t k = 0; k < 4; ++k) detection.corners[k] = {raw->p[k][0], raw->p[k][1]};
        detection.centre = {raw->c[0], raw->c[1]};
    }
    std::sort(out.begin(), out.end(), [](const TagDetection& a, const TagDetection& b) {
        return a.id != b.id ? a.id < b.id : a.decisionMargin > b.decisionMargin;
    });
    return count;
}

std::vector<TagDetection> TagDetector::detect(const cv::Mat& image) {
    std::vector<TagDetection> out;
    detectInto(image, out);
    return out;
}

} // namespace lightskin::tracking
