#pragma once
// An image file a command will write (doctor --out, golden-diff --diff, live --snapshot): checked
// before any work, so a name OpenCV cannot encode fails at once with the option's name instead of
// OpenCV's own text after the work is done.
#include "CliSupport.h"

#include <lightskin/core/Error.h>

#include <opencv2/imgcodecs.hpp>

#include <string>

namespace lightskin::apps {

/// checkOutputFile, then: `file`'s extension is one OpenCV writes (.png, .jpg, .tif, ...).
inline void checkImageOutput(const std::filesystem::path& file, const InputPaths& inputs, std::string_view option) {
    checkOutputFile(file, inputs, option);
    const std::string extension = file.extension().string();
    if (extension.size() < 2 || !cv::haveImageWriter(file.string()))
        throw Error(file.string(), std::nullopt,
                    std::string(option) + " needs an image file name ending in .png (or another format OpenCV writes" +
                        (extension.size() < 2 ? ")" : "; it cannot write '" + extension + "')"));
}

} // namespace lightskin::apps
