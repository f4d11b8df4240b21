#include "PrtSmallScale.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/ImageFile.h>
#include <lightskin/core/Log.h>
#include <lightskin/gl/TextureUpload.h>

#include <epoxy/gl.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

namespace lightskin::gi::detail {

gl::Texture loadSmallScaleTexture(const std::filesystem::path& file, SmallScaleMode mode) {
    LIGHTSKIN_ASSERT(mode != SmallScaleMode::Off, "lightskin::gi::detail::loadSmallScaleTexture(): no map to load");
    // ANYDEPTH keeps 16-bit PNG/TIFF maps; COLOR turns a grey map into equal channels (R = the grey value).
    const cv::Mat image = readImageFile(file, cv::IMREAD_COLOR | cv::IMREAD_ANYDEPTH);
    cv::Mat wide;
    if (image.depth() == CV_8U) {
        image.convertTo(wide, CV_16U, 257.0);
    } else if (image.depth() == CV_16U) {
        wide = image;
    } else {
        throw Error(file.string(), std::nullopt, "small-scale map: 8- or 16-bit channels expected");
    }
    cv::Mat pixels;
    GLenum internalFormat = GL_R16, format = GL_RED;
    if (mode == SmallScaleMode::OcclusionMap) {
        cv::extractChannel(wide, pixels, 2); // OpenCV's BGR: red, the channel glTF's occlusion reads
    } else {
        cv::cvtColor(wide, pixels, cv::COLOR_BGR2RGBA);
        internalFormat = GL_RGBA16;
        format = GL_RGBA;
    }
    cv::flip(pixels, pixels, 0);
    if (!pixels.isContinuous()) pixels = pixels.clone();
    return gl::createMipmappedRepeatingTexture2D(internalFormat, pixels.cols, pixels.rows, format, GL_UNSIGNED_SHORT,
                                                 pixels.data);
}

PrtSmallScale PrtSmallScale::create(std::span<const MeshInstance> instances) {
    PrtSmallScale out;
    std::map<std::pair<std::string, int>, std::size_t> loaded; // (file, mode) -> index in textures_
    for (const MeshInstance& instance : instances) {
        SmallScaleBinding binding;
        const Material& material = instance.material;
        std::string file;
        if (!material.occlusionTexture.empty()) {
            binding = {SmallScaleMode::OcclusionMap, 0, material.occlusionStrength};
            file = material.occlusionTexture;
        } else if (!material.normalTexture.empty()) {
            binding = {SmallScaleMode::NormalMap, 0, material.normalScale};
            file = material.normalTexture;
        }
        if (binding.mode != SmallScaleMode::Off && (instance.mesh == nullptr || instance.mesh->texcoords.empty())) {
            log::warning("multiscale-prt: mesh " + std::to_string(instance.meshId) + ": small-scale map '" + file +
                         "' ignored: the mesh has no texture coordinates");
            binding = {};
        }
        if (binding.mode != SmallScaleMode::Off) {
            const auto key = std::make_pair(file, int(binding.mode));
            auto found = loaded.find(key);
            if (found == loaded.end()) {
                out.textures_.push_back(loadSmallScaleTexture(file, binding.mode));
                found = loaded.emplace(key, out.textures_.size() - 1).first;
            }
            binding.texture = out.textures_[found->second].id();
        }
        out.bindings_.push_back(binding);
    }
    return out;
}

} // namespace lightskin::gi::detail
