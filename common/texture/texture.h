#pragma once
// Image textures of a scene, looked up through OpenImageIO's TextureSystem (included only in
// texture.cpp), unfiltered or filtered over a ray footprint (Igehy 1999, §4). UV (0,0) is the
// image's lower-left corner, as in OBJ files.
//
// Mip-mapping. The TextureSystem's cache is file-oriented and filters only tiled, mip-mapped
// files. Its `automip` would build the pyramid from the stored values, which for 8-bit sRGB
// images are encoded ones (averaging encoded values darkens: a black/white checker would become
// linear 0.214 instead of 0.5), and OIIO 2.4's TextureSystem has no colour transform to apply
// first. So the constructor reads each image, applies the sRGB curve when Texture::srgb says so,
// and writes a tiled, box-filtered mip-map of the linear values (ImageBufAlgo::make_texture, a
// TIFF file: OpenEXR 3.1's tiled writer deadlocks when a write fails, as on a full disk) into a
// private temporary directory ($TMPDIR/mrt-textures-PID-XXXXXX), removed by
// the destructor, by SIGINT, SIGTERM and SIGHUP, or, after a crash, by the next run
// (common/system/temporary_directory.h). (OIIO 2.4 could read the mip-map from memory through an
// IOProxy, but make_texture writes only to a named file.)
// 8-bit and half sources are stored as half floats (relative step 2^-11, finer than 8-bit sRGB
// anywhere), others as float. Non-finite texels become 0. A file that is already tiled and
// mip-mapped and needs no linearisation (a `maketx` .tx, a mip-mapped .exr) is used in place.
// Conversion costs one to two seconds per 2048² texture (two cores), once, in the constructor.
//
// Channels: a colour texture of one or two channels (grey, grey + alpha) is grey, of three or
// more RGB, extras ignored. An opacity texture (TextureChannel::Opacity) keeps one channel: the
// file's alpha where it has one (OpenImageIO's alpha channel, else the second of two or the
// fourth of four or more), else its first; it is never linearised.

#include "common/math/math.h"
#include "common/scene/scene.h"
#include "common/system/budgets.h"
#include "common/system/enum_names.h"

#include <iosfwd>
#include <memory>
#include <string>

namespace mrt {

/// How texture lookups are filtered, after Igehy 1999 Figs. 3 and 4.
enum class TextureFilter {
    /// Bilinear on the full-resolution image; the footprint is ignored (Fig. 3a).
    None,
    /// Isotropic trilinear mip-mapping as Trilinear. The caller derives the footprint from the
    /// distance the ray travelled (Fig. 3b) rather than from ray differentials; inside the
    /// sampler it is the same filter.
    Distance,
    /// Isotropic trilinear mip-mapping at the level of detail of eq. 26: one square filter whose
    /// width is the longer of the two footprint derivatives in texture space (Fig. 4a).
    Trilinear,
    /// Anisotropic: the level of detail follows the footprint's minor axis and bilinear probes
    /// are averaged along its major axis (OpenImageIO's MipModeAniso, Fig. 4b), with the
    /// derivatives scaled by 0.75 so that its extent is the pixel's (texture.cpp).
    Anisotropic,
};

/// Each filter's name on the command line and in --stats.
inline constexpr EnumNames<TextureFilter, 4> kTextureFilterNames{{{
    {TextureFilter::None, "none"},
    {TextureFilter::Distance, "distance"},
    {TextureFilter::Trilinear, "trilinear"},
    {TextureFilter::Anisotropic, "anisotropic"},
}}};

/// Parses "none" | "distance" | "trilinear" | "anisotropic"; throws mrt::Error otherwise.
TextureFilter parse_texture_filter(const std::string& text);

/// The spelling parse_texture_filter reads back to the same filter.
std::string to_string(TextureFilter filter);

std::ostream& operator<<(std::ostream& os, TextureFilter filter);

/// Texture-coordinate derivatives with respect to the image x and y (Igehy's ∂T/∂x and ∂T/∂y,
/// eq. 25 with a one-pixel spacing), in the mesh's uv space, before the material's uv transform.
/// Zero is a point sample.
struct UvFootprint {
    Vec2f duv_dx{0.0f, 0.0f};  ///< ∂(u, v)/∂x: uv change from one pixel to the next along x.
    Vec2f duv_dy{0.0f, 0.0f};  ///< ∂(u, v)/∂y: uv change from one pixel to the next along y.
};

std::ostream& operator<<(std::ostream& os, const UvFootprint& footprint);

/// Looks up a scene's textures. All lookups are const and thread-safe (OpenImageIO's per-thread
/// state is cached per thread), allocate nothing outside OpenImageIO's tile cache, and
/// return finite colours for any footprint (non-finite derivatives are treated as a point
/// sample; derivatives longer than the whole texture are shortened to its width, which already
/// averages the whole image).
class TextureSampler {
  public:
    /// Maximum ratio of the footprint's major to minor axis in the Anisotropic filter. A
    /// longer footprint keeps its major axis and has its minor axis widened to major / 16
    /// (OpenImageIO's conservative_filter), so it is blurred a little rather than aliased; it
    /// also bounds the work per lookup at 2 · 16 − 1 bilinear probes per mip level.
    static constexpr float kMaxAnisotropy = 16.0f;

    /// Opens and mip-maps every texture of the scene (see the file comment); throws mrt::Error
    /// naming a file that cannot be read or converted.
    /// A texture of more pixels than `budgets.pixels` is refused from its header, before its
    /// pixels are read.
    explicit TextureSampler(const Scene& scene, TextureFilter filter = TextureFilter::None,
                            const Budgets& budgets = Budgets{});
    ~TextureSampler();
    TextureSampler(const TextureSampler&) = delete;
    TextureSampler& operator=(const TextureSampler&) = delete;

    /// The filter applied by the footprint overloads.
    TextureFilter filter() const { return m_filter; }

    /// Linear RGB of texture `index` at texture coordinates `uv` (after the material's uv
    /// transform), bilinear on the full-resolution image, wrapping periodically: the None filter,
    /// whatever filter() is.
    Rgb lookup(int index, const Vec2f& uv) const;

    /// Linear RGB of texture `index` at `uv`, filtered with filter() over `footprint`, whose
    /// derivatives are in the same (texture) space as `uv`. Wraps periodically.
    Rgb lookup(int index, const Vec2f& uv, const UvFootprint& footprint) const;

    /// Diffuse albedo of `material` at mesh coordinates `uv`: its diffuse colour, times its
    /// texture if any (unfiltered, as lookup(index, uv)).
    Rgb diffuse(const Material& material, const Vec2f& uv) const {
        if (material.texture < 0) {
            return material.diffuse;
        }
        return material.diffuse * lookup(material.texture, material.uv_transform * uv);
    }

    /// Diffuse albedo of `material` at mesh coordinates `uv` with the texture filtered over
    /// `footprint` (mesh uv space): the uv transform's linear part maps the derivatives, so a
    /// texture repeated 4 times is filtered over a 4 times wider footprint.
    Rgb diffuse(const Material& material, const Vec2f& uv, const UvFootprint& footprint) const {
        if (material.texture < 0) {
            return material.diffuse;
        }
        return material.diffuse *
               lookup(material.texture, material.uv_transform * uv, mapped(material, footprint));
    }

    /// Opacity of `material`'s cut-out at mesh coordinates `uv`: 1 without one, else its
    /// opacity texture there, unfiltered (as lookup(index, uv)).
    float opacity(const Material& material, const Vec2f& uv) const {
        if (!material.cut_out()) {
            return 1.0f;
        }
        return lookup(material.opacity_texture, material.uv_transform * uv).x();
    }

    /// The same filtered over `footprint` (mesh uv space), as diffuse(material, uv, footprint):
    /// the share of the footprint the cut-out leaves standing.
    float opacity(const Material& material, const Vec2f& uv, const UvFootprint& footprint) const {
        if (!material.cut_out()) {
            return 1.0f;
        }
        return lookup(material.opacity_texture, material.uv_transform * uv,
                      mapped(material, footprint))
            .x();
    }

  private:
    /// A footprint in mesh uv space mapped into `material`'s texture space: the uv transform's
    /// linear part maps the derivatives.
    static UvFootprint mapped(const Material& material, const UvFootprint& footprint) {
        const auto linear = material.uv_transform.linear();
        return {linear * footprint.duv_dx, linear * footprint.duv_dy};
    }

    struct Impl;
    std::unique_ptr<Impl> m_impl;
    TextureFilter m_filter;
};

}  // namespace mrt
