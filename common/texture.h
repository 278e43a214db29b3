#pragma once
// Image textures of a scene, looked up through OpenImageIO's TextureSystem (included only in
// texture.cpp). UV (0,0) is the image's lower-left corner, as in OBJ files.

#include "common/math.h"
#include "common/scene.h"

#include <memory>

namespace mrt {

class TextureSampler {
public:
    /// Opens every texture of the scene; throws mrt::Error naming a file that cannot be read.
    explicit TextureSampler(const Scene& scene);
    ~TextureSampler();
    TextureSampler(const TextureSampler&) = delete;
    TextureSampler& operator=(const TextureSampler&) = delete;

    /// Linear RGB of texture `index` at texture coordinates `uv` (after the material's uv
    /// transform), bilinear on the full-resolution image, wrapping periodically.
    Rgb lookup(int index, const Vec2f& uv) const;

    /// Diffuse albedo of `material` at `uv`: its diffuse colour, times its texture if any.
    Rgb diffuse(const Material& material, const Vec2f& uv) const {
        if (material.texture < 0) {
            return material.diffuse;
        }
        return material.diffuse * lookup(material.texture, material.uv_transform * uv);
    }

private:
    struct Impl;
    std::unique_ptr<Impl> m_impl;
};

}  // namespace mrt
