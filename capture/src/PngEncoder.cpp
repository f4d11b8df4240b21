#include "PngEncoder.h"

#include <lightskin/core/Error.h>

#include <csetjmp>
#include <cstring>
#include <png.h>
#include <zlib.h>

namespace lightskin::capture::detail {

namespace {

/// Appends libpng's output to a buffer whose capacity was reserved for the worst case (stored,
/// uncompressed data), so the callback never reallocates and never throws through libpng's C code.
struct Sink {
    std::vector<unsigned char>* out = nullptr;
    bool overflow = false;
};

void writeToSink(png_structp png, png_bytep data, png_size_t size) {
    auto* sink = static_cast<Sink*>(png_get_io_ptr(png));
    std::vector<unsigned char>& out = *sink->out;
    if (out.size() + size > out.capacity()) {
        sink->overflow = true;
        return;
    }
    const std::size_t at = out.size();
    out.resize(at + size); // within capacity: no allocation
    std::memcpy(out.data() + at, data, size);
}

void flushSink(png_structp) {}

/// The libpng calls; libpng reports errors by longjmp back to here, so this function holds no
/// object with a destructor (a longjmp over one would skip it). Returns false on a libpng error.
bool encodeRows(png_structp png, png_infop info, const cv::Mat& image, Sink& sink) {
    if (setjmp(png_jmpbuf(png))) return false;
    png_set_write_fn(png, &sink, writeToSink, flushSink);
    const bool sixteen = image.depth() == CV_16U;
    png_set_IHDR(png, info, png_uint_32(image.cols), png_uint_32(image.rows), sixteen ? 16 : 8,
                 image.channels() == 1 ? PNG_COLOR_TYPE_GRAY : PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_UP);
    png_set_compression_level(png, 1);
    png_set_compression_strategy(png, Z_RLE);
    png_write_info(png, info);
    if (sixteen) png_set_swap(png);              // PNG stores 16-bit samples big-endian
    if (image.channels() == 3) png_set_bgr(png); // OpenCV's BGR order
    for (int row = 0; row < image.rows; ++row) png_write_row(png, image.ptr<png_byte>(row));
    png_write_end(png, info);
    return true;
}

} // namespace

void encodePngFast(const cv::Mat& image, std::vector<unsigned char>& out) {
    if (image.type() != CV_8UC3 && image.type() != CV_16UC1)
        throw Error("encodePngFast: only 8-bit BGR and 16-bit grey images are encoded");
    // Worst case: every row stored uncompressed (filter byte + data) in 64 KiB deflate blocks of 5
    // bytes overhead each, plus the chunks' headers: reserved once, reused for every frame after.
    const std::size_t rowBytes = image.elemSize() * std::size_t(image.cols) + 1;
    const std::size_t raw = rowBytes * std::size_t(image.rows);
    out.clear();
    out.reserve(raw + raw / 16000 * 5 + 64 * 1024);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    if (png == nullptr) throw Error("encodePngFast: png_create_write_struct failed");
    png_infop info = png_create_info_struct(png);
    Sink sink{&out};
    const bool ok = info != nullptr && encodeRows(png, info, image, sink);
    png_destroy_write_struct(&png, info != nullptr ? &info : nullptr);
    if (!ok) throw Error("encodePngFast: libpng failed to encode the image");
    if (sink.overflow) throw Error("encodePngFast: the PNG outgrew its worst-case size");
}

} // namespace lightskin::capture::detail
