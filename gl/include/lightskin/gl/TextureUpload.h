#pragma once
// Uploads of images that objects sample with texture coordinates (albedo maps, occlusion and normal
// maps): a full mipmap chain, trilinear filtering and repeat wrapping, as OBJ and glTF expect.

#include <lightskin/gl/Objects.h>

namespace lightskin::gl {

/// A 2D texture of `width` x `height` texels with all mip levels, level 0 from `pixels` (tightly
/// packed rows, bottom row first as GL expects; not kept), the others generated; min filter
/// GL_LINEAR_MIPMAP_LINEAR, mag GL_LINEAR, wrap GL_REPEAT on s and t. `format`/`type` describe
/// `pixels` as for glTextureSubImage2D. Leaves GL_UNPACK_ALIGNMENT at GL's default, 4.
/// Needs a current GL 4.5 context.
Texture createMipmappedRepeatingTexture2D(GLenum internalFormat, GLsizei width, GLsizei height, GLenum format,
                                          GLenum type, const void* pixels);

} // namespace lightskin::gl
