#include <lightskin/gl/TextureUpload.h>

#include <algorithm>
#include <bit>

namespace lightskin::gl {

Texture createMipmappedRepeatingTexture2D(GLenum internalFormat, GLsizei width, GLsizei height, GLenum format,
                                          GLenum type, const void* pixels) {
    const auto largest = static_cast<unsigned>(std::max(width, height));
    const auto levels = static_cast<GLsizei>(std::bit_width(largest)); // 1 + floor(log2(largest))
    Texture texture = Texture::create2D(internalFormat, width, height, levels);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1); // rows are tightly packed whatever their width
    glTextureSubImage2D(texture.id(), 0, 0, 0, width, height, format, type, pixels);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glGenerateTextureMipmap(texture.id());
    glTextureParameteri(texture.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTextureParameteri(texture.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(texture.id(), GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTextureParameteri(texture.id(), GL_TEXTURE_WRAP_T, GL_REPEAT);
    return texture;
}

} // namespace lightskin::gl
