#include "Families.h"

#include <lightskin/core/Error.h>
#include <lightskin/tracking/TagDetector.h>

#include <glm/geometric.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>

namespace lightskin::tracking {

namespace {
struct DetectorDeleter {
    void operator()(apriltag_detector_t* detector) const noexcept { apriltag_detector_destroy(detector); }
};
constexpr double libraryPixelOffset = 0.5;
struct DetectionsDeleter {
    void operator()(zarray_t* detections) const noexcept { apriltag_detections_destroy(detections); }
};

/// Bilinear sample of an 8-bit image at (x, y) in OpenCV's pixel convention; clamps at the border.
double sampleBilinear(const cv::Mat& image, double x, double y) {
    const double cx = std::clamp(x, 0.0, static_cast<double>(image.cols - 1) - 1e-9);
    const double cy = std::clamp(y, 0.0, static_cast<double>(image.rows - 1) - 1e-9);
    const int x0 = static_cast<int>(cx);
    const int y0 = static_cast<int>(cy);
    const int x1 = std::min(x0 + 1, image.cols - 1);
    const int y1 = std::min(y0 + 1, image.rows - 1);
    const double fx = cx - x0;
    const double fy = cy - y0;
    const auto* row0 = image.ptr<std::uint8_t>(y0);
    const auto* row1 = image.ptr<std::uint8_t>(y1);
    return (1.0 - fy) * ((1.0 - fx) * row0[x0] + fx * row0[x1]) + fy * ((1.0 - fx) * row1[x0] + fx * row1[x1]);
}

struct Line {
    glm::dvec2 point{0.0};
    glm::dvec2 direction{0.0};
};

/// Total-least-squares line through `points`.
Line fitLine(const std::vector<glm::dvec2>& points) {
    glm::dvec2 mean(0.0);
    for (const glm::dvec2& p : points) mean += p;
    mean /= static_cast<double>(points.size());
    double sxx = 0.0, sxy = 0.0, syy = 0.0;
    for (const glm::dvec2& p : points) {
        const glm::dvec2 d = p - mean;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    // Direction = eigenvector of the largest eigenvalue of the 2x2 scatter matrix.
    const double angle = 0.5 * std::atan2(2.0 * sxy, sxx - syy);
    return {mean, {std::cos(angle), std::sin(angle)}};
}

bool intersect(const Line& a, const Line& b, glm::dvec2& out) {
    const double denominator = a.direction.x * b.direction.y - a.direction.y * b.direction.x;
    if (std::abs(denominator) < 1e-6) return false;
    const glm::dvec2 d = b.point - a.point;
    const double t = (d.x * b.direction.y - d.y * b.direction.x) / denominator;
    out = a.point + t * a.direction;
    return true;
}

constexpr int maxSteps = 30;
/// Smallest bit cell (pixels) whose edges are refined. Below it the blur of the edge spans most
/// of a cell and the gradient profile no longer beats the library's own fit: on lightskin synth
/// recordings (blurred GL renders, 15-40 px tags) refining smaller tags made the poses worse
/// (rotation RMS 0.28 -> 0.47 degrees), while on 48+ px tags it cuts the corner error ~3x.
constexpr double minRefinedCellPx = 6.0;

/// Re-locates the four border edges of one detection from the image gradient and intersects them.
/// Leaves the corners unchanged when an edge cannot be measured or a corner would move > 1.5 px.
void refineCorners(const cv::Mat& grey, int borderCells, bool reversedBorder, std::array<glm::dvec2, 4>& corners,
                   std::vector<glm::dvec2>& edgePoints) {
    std::array<Line, 4> lines;
    for (std::size_t edge = 0; edge < 4; ++edge) {
        const glm::dvec2 p0 = corners[edge];
        const glm::dvec2 p1 = corners[(edge + 1) % 4];
        const double length = glm::length(p1 - p0);
        if (length < minRefinedCellPx * borderCells) return; // small tag: keep the library's corners
        const glm::dvec2 along = (p1 - p0) / length;
        // Outward normal (away from the quad's centre). The border edge is dark inside, bright
        // outside (reversed-border families: the opposite), so only gradients of that sign count:
        // the edge one cell further in (border -> data bit) has the other sign and is never taken.
        glm::dvec2 normal(-along.y, along.x);
        const glm::dvec2 centre = 0.25 * (corners[0] + corners[1] + corners[2] + corners[3]);
        if (glm::dot(normal, 0.5 * (p0 + p1) - centre) < 0.0) normal = -normal;
        const double sign = reversedBorder ? -1.0 : 1.0;
        // Half a bit cell is where the next edge (a data bit) can start: search within 40 % of it.
        const double cell = length / borderCells;
        const double radius = std::clamp(0.4 * cell, 0.6, 3.0);
        const double step = 0.1;
        const int steps = std::min(static_cast<int>(radius / step), maxSteps);
        const int samples = std::clamp(static_cast<int>(length / 2.0), 6, 40);
        edgePoints.clear();
        for (int i = 0; i < samples; ++i) {
            // Stay away from the corners, where the neighbouring edge bends the profile.
            const double t = 0.12 + 0.76 * (static_cast<double>(i) + 0.5) / samples;
            const glm::dvec2 q = p0 + t * (p1 - p0);
            // Central differences of intensity along the normal, one per 0.1 px.
            std::array<double, 2 * maxSteps + 1> gradient{};
            std::size_t bestIndex = 0;
            const auto count = static_cast<std::size_t>(2 * steps + 1);
            for (std::size_t k = 0; k < count; ++k) {
                const double o = (static_cast<double>(k) - steps) * step;
                const glm::dvec2 a = q + (o - 0.5) * normal;
                const glm::dvec2 b = q + (o + 0.5) * normal;
                gradient[k] = std::max(0.0, sign * (sampleBilinear(grey, b.x, b.y) - sampleBilinear(grey, a.x, a.y)));
                if (gradient[k] > gradient[bestIndex]) bestIndex = k;
            }
            // An interior peak with real contrast only (a flat profile is no edge).
            if (bestIndex == 0 || bestIndex + 1 == count || gradient[bestIndex] < 10.0) continue;
            // Centroid of the part of the gradient profile above half its peak: the edge position for any
            // symmetric blur, and free of the plateau a sharp edge leaves after bilinear sampling.
            const double half = 0.5 * gradient[bestIndex];
            double weightSum = 0.0;
            double weightedIndex = 0.0;
            for (std::size_t k = bestIndex; k < count && gradient[k] > half; ++k) {
                weightSum += gradient[k] - half;
                weightedIndex += (gradient[k] - half) * static_cast<double>(k);
            }
            for (std::size_t k = bestIndex; k-- > 0 && gradient[k] > half;) {
                weightSum += gradient[k] - half;
                weightedIndex += (gradient[k] - half) * static_cast<double>(k);
            }
            if (weightSum <= 0.0) continue;
            const double alongNormal = (weightedIndex / weightSum - steps) * step;
            edgePoints.push_back(q + alongNormal * normal);
        }
        if (edgePoints.size() < 4) return;
        Line line = fitLine(edgePoints);
        // One pass without outliers (a data bit or a specular spot at one sample).
        const glm::dvec2 lineNormal(-line.direction.y, line.direction.x);
        std::erase_if(edgePoints,
                      [&](const glm::dvec2& p) { return std::abs(glm::dot(p - line.point, lineNormal)) > 0.3; });
        if (edgePoints.size() < 4) return;
        lines[edge] = fitLine(edgePoints);
    }
    std::array<glm::dvec2, 4> refined;
    for (std::size_t corner = 0; corner < 4; ++corner) {
        if (!intersect(lines[(corner + 3) % 4], lines[corner], refined[corner])) return;
        if (glm::length(refined[corner] - corners[corner]) > 1.5) return;
    }
    corners = refined;
}

} // namespace

struct TagDetector::Impl {
    DetectorSettings settings;
    // Destruction order matters: the detector refers to the family, so it is declared after it
    // (destroyed first).
    detail::FamilyPtr family;
    std::unique_ptr<apriltag_detector_t, DetectorDeleter> detector;
    cv::Mat grey;                       // conversion buffer, reused
    cv::Mat upsampled;                  // DetectorSettings::upsample buffer, reused
    std::vector<glm::dvec2> edgePoints; // refineCorners scratch, reused
};

TagDetector TagDetector::create(const DetectorSettings& settings) {
    if (const auto problem = findDetectorSettingProblem(settings))
        throw Error("detector settings", std::nullopt, "/" + problem->key + ": " + problem->cause);

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

TagDetector::TagDetector(std::unique_ptr<Impl> impl)
    : impl_(std::move(impl)) {}
TagDetector::TagDetector(TagDetector&&) noexcept = default;
TagDetector& TagDetector::operator=(TagDetector&&) noexcept = default;
TagDetector::~TagDetector() = default;

const DetectorSettings& TagDetector::settings() const noexcept { return impl_->settings; }

int TagDetector::detectInto(const cv::Mat& image, std::vector<TagDetection>& out) {
    LIGHTSKIN_ASSERT(impl_ != nullptr, "detector was moved from");
    LIGHTSKIN_ASSERT(image.depth() == CV_8U &&
                         (image.channels() == 1 || image.channels() == 3 || image.channels() == 4),
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
    // The library sees the enlarged image with upsample > 1. cv::resize maps input pixel centres x to
    // (x + 0.5) f - 0.5, so a library corner u (OpenCV convention) is at (u + 0.5) / f - 0.5.
    const cv::Mat* libraryImage = grey;
    const double factor = static_cast<double>(impl_->settings.upsample);
    if (impl_->settings.upsample > 1) {
        cv::resize(*grey, impl_->upsampled, cv::Size(), factor, factor, cv::INTER_CUBIC);
        libraryImage = &impl_->upsampled;
    }
    const auto toInput = [factor](double libraryCoordinate) {
        return (libraryCoordinate - libraryPixelOffset + 0.5) / factor - 0.5;
    };
    // The library only reads the pixels; image_u8_t has no const variant.
    image_u8_t view{libraryImage->cols, libraryImage->rows, static_cast<std::int32_t>(libraryImage->step[0]),
                    const_cast<std::uint8_t*>(libraryImage->data)};
    const std::unique_ptr<zarray_t, DetectionsDeleter> detections(
        apriltag_detector_detect(impl_->detector.get(), &view));
    const int count = zarray_size(detections.get());
    for (int i = 0; i < count; ++i) {
        apriltag_detection_t* raw = nullptr;
        zarray_get(detections.get(), i, &raw);
        if (raw->hamming > impl_->settings.maxHamming || raw->decision_margin < impl_->settings.minDecisionMargin)
            continue;
        TagDetection& detection = out.emplace_back();
        detection.id = raw->id;
        detection.hamming = raw->hamming;
        detection.decisionMargin = raw->decision_margin;
        // libapriltag 3.3 puts pixel centres at +0.5 (an edge between pixels 51 and 52 is reported
        // at 52.0, measured on rendered tags); lightskin uses OpenCV's convention (centres at integers).
        for (std::size_t k = 0; k < 4; ++k) detection.corners[k] = {toInput(raw->p[k][0]), toInput(raw->p[k][1])};
        detection.centre = {toInput(raw->c[0]), toInput(raw->c[1])};
        if (impl_->settings.refineCorners)
            refineCorners(*grey, impl_->family->width_at_border, impl_->family->reversed_border, detection.corners,
                          impl_->edgePoints);
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
