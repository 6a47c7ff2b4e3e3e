#pragma once
// Image textures as glTF defines them: an 8-bit RGBA image read through a sampler (a wrap mode
// per axis, bilinear or nearest) at texture coordinates mapped by KHR_texture_transform. Plain
// data and free functions: a lookup is four texel loads and a blend, on the hot path of every
// textured hit.
//
// Why not OpenImageIO's TextureSystem: its MIP-mapped, filtered lookups are driven by the
// footprint of a lookup (derivatives of the texture coordinates), which a path tracer without
// ray differentials does not have; a pixel's many samples already average the texture over the
// pixel. Its images come from files through a tile cache, while glTF's are in memory (data: URIs,
// GLB buffers), and each lookup would pay a cache query. Minified textures at low sample counts
// alias where MIP maps would blur (docs/materials.md).
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace tessera {

enum class Wrap : uint8_t { repeat, clamp, mirror };

struct TextureImage {
    int width = 0, height = 0;
    std::vector<uint8_t> rgba;  // 4 bytes a texel, rows from the top: uv (0, 0) is the top-left corner
};

// A glTF texture: an image and how it is sampled.
struct Texture {
    uint32_t image = 0;
    Wrap wrap_s = Wrap::repeat, wrap_t = Wrap::repeat;
    bool nearest = false;  // magFilter NEAREST; otherwise bilinear
};

// Where a material reads a texture: which one, from which coordinate set, and the affine map
// from that set to the texture's coordinates (KHR_texture_transform; the identity without it).
struct TextureSlot {
    int32_t texture = -1;  // none
    uint8_t texcoord = 0;  // TEXCOORD_0 or TEXCOORD_1
    glm::vec3 row_u{1.f, 0.f, 0.f}, row_v{0.f, 1.f, 0.f};  // u' = row_u · (u, v, 1), v' = row_v · (u, v, 1)
    float scale = 1.f;     // normalTexture.scale (strength of the normal map)
    bool used() const { return texture >= 0; }
    glm::vec2 map(glm::vec2 uv) const {
        const glm::vec3 h(uv, 1.f);
        return {glm::dot(row_u, h), glm::dot(row_v, h)};
    }
};

// KHR_texture_transform: scale, then rotate by `rotation` radians (counter-clockwise as the
// image is seen), then offset: T · R · S as the extension writes it.
void set_texture_transform(TextureSlot& slot, glm::vec2 offset, float rotation, glm::vec2 scale);

// sRGB-encoded 8-bit value -> linear, exactly by the sRGB curve (a table).
extern const std::array<float, 256> kSrgbToLinear;

// The texture at `uv` (already mapped), RGBA with RGB linear: sRGB-decoded first when `srgb`
// (base colour and emissive), as the raw value / 255 otherwise (data: metallic-roughness,
// normals). Alpha is always linear. Filtering blends decoded values.
glm::vec4 texture_lookup(const TextureImage& image, const Texture& texture, glm::vec2 uv, bool srgb);

// The mean of the image's RGB (sRGB-decoded when `srgb`): the power of a textured emitter.
glm::vec3 texture_mean(const TextureImage& image, bool srgb);

}  // namespace tessera
