#include "common/scene_io/mtl_materials.h"

#include <fmt/format.h>

#include <algorithm>

namespace mrt {

namespace {

/// The illumination models that ray trace a reflection (3 to 7) and a refraction (4, 6, 7, 9).
bool mirrors(int illum) {
    return illum >= 3 && illum <= 7;
}
bool refracts(int illum) {
    return illum == 4 || illum == 6 || illum == 7 || illum == 9;
}

}  // namespace

Material material_from_mtl(const MtlMaterial& mtl, const std::filesystem::path& library,
                           std::string name, const MtlTextureIndex& texture,
                           const MtlWarning& warn) {
    Material m;
    m.name = std::move(name);
    const int illum = mtl.illum.value_or(2);
    m.diffuse = mtl.diffuse.value_or(Rgb(0.8f, 0.8f, 0.8f));
    // illum 0 and 1 have no highlight.
    m.specular = illum >= 2 ? mtl.specular.value_or(Rgb::Zero()) : Rgb::Zero();
    m.phong_exponent = mtl.exponent.value_or(m.phong_exponent);
    m.emission = mtl.emission.value_or(Rgb::Zero());
    if (mirrors(illum)) {
        // The mirror is untinted: its strength is the specular colour's largest component.
        m.reflectivity = std::clamp(mtl.specular.value_or(Rgb::Zero()).maxCoeff(), 0.0f, 1.0f);
    }
    const float dissolve = mtl.dissolve.value_or(1.0f);
    if (refracts(illum)) {
        // Glass: what d leaves through, else the transmission filter's strength, else all.
        m.transparency = dissolve < 1.0f    ? 1.0f - dissolve
                         : mtl.transmission ? std::clamp(mtl.transmission->maxCoeff(), 0.0f, 1.0f)
                                            : 1.0f;
        m.ior = mtl.ior.value_or(m.ior);
    } else if (dissolve < 1.0f) {
        // See-through without refraction: transmitted straight on.
        m.transparency = 1.0f - dissolve;
        m.ior = 1.0f;
    }
    m.transparency = std::min(m.transparency, 1.0f - m.reflectivity);
    const auto uv_transform = [](const MtlTextureMap& map) {
        Affine2f transform = Affine2f::Identity();
        transform.translate(map.offset);
        transform.scale(map.scale);
        return transform;
    };
    if (mtl.diffuse_map) {
        m.texture = texture(mtl.diffuse_map->file, TextureChannel::Colour);
        m.uv_transform = uv_transform(*mtl.diffuse_map);
    }
    if (mtl.alpha_map) {
        m.opacity_texture = texture(mtl.alpha_map->file, TextureChannel::Opacity);
        // One uv transform serves both maps: the colour's, when there is one.
        if (!mtl.diffuse_map) {
            m.uv_transform = uv_transform(*mtl.alpha_map);
        } else if ((mtl.alpha_map->scale != mtl.diffuse_map->scale ||
                    mtl.alpha_map->offset != mtl.diffuse_map->offset) &&
                   warn) {
            warn(fmt::format(
                "{}: line {}: 'map_d' of material '{}' has other -s/-o options than "
                "its 'map_Kd' (line {}); the cut-out is placed as the colour is",
                library.string(), mtl.alpha_map->line, mtl.name, mtl.diffuse_map->line));
        }
    }
    return m;
}

}  // namespace mrt
