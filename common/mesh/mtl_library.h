#pragma once
// Wavefront material libraries (.mtl), as OBJ files name them with `mtllib`: the statements as
// written, checked, with the line each came from. What they mean for rendering (the mapping to
// the project's Material) is the scene loader's (common/scene_io/mtl_materials.h).
//
// Read: newmtl, Kd, Ks, Ke, Ka, Ns, Ni, d, Tr, Tf, illum, map_Kd, map_d (texture options -s and
// -o kept; -blendu, -blendv, -boost, -mm, -t, -texres, -clamp, -bm, -imfchan, -type skipped
// with one warning each). Colours are "r [g b]" (one value is grey); spectral and CIE XYZ
// colours are refused. Any other statement is reported once per keyword as a warning naming
// the file and line, and skipped. '#' begins a comment, also after a statement.

#include "common/math/math.h"

#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace mrt {

/// A texture statement (map_Kd, map_d): its file and the placement options the mapping uses.
struct MtlTextureMap {
    std::filesystem::path file;  ///< Resolved against the library's directory; exists.
    Vec2f scale{1.0f, 1.0f};     ///< -s u v: texture coordinates are multiplied by it...
    Vec2f offset{0.0f, 0.0f};    ///< -o u v: ...then moved by it.
    std::size_t line = 0;
};

/// One `newmtl` block; a statement the block does not have is empty.
struct MtlMaterial {
    std::string name;
    std::size_t line = 0;                      ///< Of its newmtl.
    std::optional<Rgb> diffuse;                ///< Kd
    std::optional<Rgb> specular;               ///< Ks
    std::optional<Rgb> emission;               ///< Ke
    std::optional<Rgb> transmission;           ///< Tf
    std::optional<float> exponent;             ///< Ns (≥ 0)
    std::optional<float> ior;                  ///< Ni (> 0)
    std::optional<float> dissolve;             ///< d, or 1 − Tr, in [0, 1]; 1 is opaque.
    std::optional<int> illum;                  ///< illum, 0..10
    std::optional<MtlTextureMap> diffuse_map;  ///< map_Kd
    std::optional<MtlTextureMap> alpha_map;    ///< map_d
};

struct MtlLibrary {
    std::filesystem::path file;
    std::vector<MtlMaterial> materials;  ///< In file order, names unique.

    /// The material of that name, or null.
    const MtlMaterial* find(std::string_view name) const;
};

using MtlWarning = std::function<void(const std::string&)>;

/// Parses `text` as the library `file` (whose directory texture paths are relative to). Throws
/// mrt::Error naming the file and line: a statement before any newmtl, a repeated material name,
/// a wrong number of values or a value out of range, a spectral or XYZ colour, a texture
/// statement without a file or whose file does not exist. `warn` (may be empty) receives one
/// message per unknown keyword and per skipped texture option.
MtlLibrary parse_mtl(const std::filesystem::path& file, std::string_view text,
                     const MtlWarning& warn = {});

/// Reads and parses the library `file`; throws mrt::Error naming it when it cannot be read.
MtlLibrary read_mtl(const std::filesystem::path& file, const MtlWarning& warn = {});

}  // namespace mrt
