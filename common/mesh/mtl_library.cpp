#include "common/mesh/mtl_library.h"

#include "common/mesh/format_scan.h"
#include "common/system/error.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>

namespace mrt {

namespace {

namespace fs = std::filesystem;
using mesh_io::LineCursor;
using mesh_io::parse_integer;
using mesh_io::parse_real;

/// Texture options and how many values each takes (the MTL specification's list); only -s and
/// -o are used, the rest are skipped with a warning.
struct TextureOption {
    std::string_view name;
    std::size_t min_values;
    std::size_t max_values;
    bool numeric;
};
constexpr std::array<TextureOption, 12> kTextureOptions{{
    {"-s", 1, 3, true},
    {"-o", 1, 3, true},
    {"-t", 1, 3, true},
    {"-blendu", 1, 1, false},
    {"-blendv", 1, 1, false},
    {"-boost", 1, 1, true},
    {"-mm", 2, 2, true},
    {"-texres", 1, 1, true},
    {"-clamp", 1, 1, false},
    {"-bm", 1, 1, true},
    {"-imfchan", 1, 1, false},
    {"-type", 1, 1, false},
}};

/// A statement's text without its comment: '#' at the start or after white space.
std::string_view strip_comment(std::string_view line) {
    for (std::size_t i = 0; i < line.size(); ++i) {
        if (line[i] == '#' && (i == 0 || mesh_io::is_space(line[i - 1]))) {
            return line.substr(0, i);
        }
    }
    return line;
}

class MtlParser {
  public:
    MtlParser(const fs::path& file, const MtlWarning& warn) : m_file(file), m_warn(warn) {
        m_library.file = file;
    }

    MtlLibrary run(std::string_view text) {
        LineCursor lines(text);
        std::string_view raw;
        while (lines.next(raw)) {
            m_line = lines.number();
            const std::string_view statement = mesh_io::trim(strip_comment(raw));
            mesh_io::split_tokens(statement, m_tokens);
            if (m_tokens.empty()) {
                continue;
            }
            m_rest = mesh_io::trim(statement.substr(m_tokens[0].size()));
            read_statement(m_tokens[0]);
        }
        return std::move(m_library);
    }

  private:
    [[noreturn]] void fail(const std::string& message) const {
        throw Error(m_file, fmt::format("line {}", m_line), message);
    }

    void warn_once(const std::string& key, const std::string& message) {
        if (m_warn && m_warned.insert(key).second) {
            m_warn(fmt::format("{}: line {}: {}", m_file.string(), m_line, message));
        }
    }

    MtlMaterial& current(std::string_view keyword) {
        if (m_library.materials.empty()) {
            fail(fmt::format("'{}' before any 'newmtl'", keyword));
        }
        return m_library.materials.back();
    }

    void read_statement(std::string_view keyword) {
        if (keyword == "newmtl") {
            read_newmtl();
        } else if (keyword == "Kd") {
            current(keyword).diffuse = colour(keyword);
        } else if (keyword == "Ks") {
            current(keyword).specular = colour(keyword);
        } else if (keyword == "Ke") {
            current(keyword).emission = colour(keyword);
        } else if (keyword == "Tf") {
            current(keyword).transmission = colour(keyword);
        } else if (keyword == "Ka") {
            // Checked but not used: the scene's ambient light is reflected by the diffuse colour.
            current(keyword);
            colour(keyword);
        } else if (keyword == "Ns") {
            current(keyword).exponent = number(keyword, 0.0, HUGE_VAL, "at least 0");
        } else if (keyword == "Ni") {
            MtlMaterial& m = current(keyword);
            const float ior = number(keyword, 0.0, HUGE_VAL, "above 0");
            if (!(ior > 0.0f)) {
                fail(fmt::format("'Ni' is {}, expected an index of refraction above 0", ior));
            }
            m.ior = ior;
        } else if (keyword == "d") {
            read_dissolve(current(keyword), false);
        } else if (keyword == "Tr") {
            read_dissolve(current(keyword), true);
        } else if (keyword == "illum") {
            MtlMaterial& m = current(keyword);
            if (m_tokens.size() != 2) {
                fail("'illum' takes one integer, 0 to 10");
            }
            const std::optional<long long> model = parse_integer(m_tokens[1]);
            if (!model || *model < 0 || *model > 10) {
                fail(fmt::format("'illum {}': expected an integer from 0 to 10", m_tokens[1]));
            }
            m.illum = static_cast<int>(*model);
        } else if (keyword == "map_Kd") {
            current(keyword).diffuse_map = texture_map(keyword);
        } else if (keyword == "map_d") {
            current(keyword).alpha_map = texture_map(keyword);
        } else {
            warn_once(std::string(keyword),
                      fmt::format("'{}' is not supported and is ignored (reported once)", keyword));
        }
    }

    void read_newmtl() {
        if (m_rest.empty()) {
            fail("'newmtl' without a name");
        }
        const std::string name(m_rest);
        if (const auto it = m_names.find(name); it != m_names.end()) {
            fail(fmt::format("a second material '{}' (the first is on line {})", name, it->second));
        }
        m_names.emplace(name, m_line);
        MtlMaterial material;
        material.name = name;
        material.line = m_line;
        m_library.materials.push_back(std::move(material));
    }

    float value(std::string_view keyword, std::string_view token) const {
        const std::optional<double> v = parse_real(token);
        if (!v || !mesh_io::finite_as_float(*v)) {
            fail(fmt::format("'{}' has '{}', expected a finite number", keyword, token));
        }
        return static_cast<float>(*v);
    }

    /// "r", or "r g b"; every component at least 0.
    Rgb colour(std::string_view keyword) const {
        if (m_tokens.size() > 1 && (m_tokens[1] == "spectral" || m_tokens[1] == "xyz")) {
            fail(fmt::format("'{} {}' colours are not supported, expected 'r g b'", keyword,
                             m_tokens[1]));
        }
        if (m_tokens.size() != 2 && m_tokens.size() != 4) {
            fail(fmt::format("'{}' has {} values, expected 'r g b' (or one grey value)", keyword,
                             m_tokens.size() - 1));
        }
        Rgb c;
        for (int i = 0; i < 3; ++i) {
            const std::size_t token = m_tokens.size() == 2 ? 1 : static_cast<std::size_t>(i + 1);
            c[i] = value(keyword, m_tokens[token]);
            if (c[i] < 0.0f) {
                fail(fmt::format("'{}' has the negative component {}, expected at least 0", keyword,
                                 c[i]));
            }
        }
        return c;
    }

    float number(std::string_view keyword, double low, double high, const char* expected) const {
        if (m_tokens.size() != 2) {
            fail(fmt::format("'{}' has {} values, expected one", keyword, m_tokens.size() - 1));
        }
        const float v = value(keyword, m_tokens[1]);
        if (v < low || v > high) {
            fail(fmt::format("'{}' is {}, expected {}", keyword, v, expected));
        }
        return v;
    }

    /// d (opacity) or Tr (its complement), in [0, 1]; "d -halo f" is read as d f.
    void read_dissolve(MtlMaterial& m, bool transparency) {
        std::string_view keyword = m_tokens[0];
        if (!transparency && m_tokens.size() == 3 && m_tokens[1] == "-halo") {
            warn_once("d -halo", "'d -halo' is not supported; read as a constant dissolve");
            m_tokens.erase(m_tokens.begin() + 1);
        }
        const float v = number(keyword, 0.0, 1.0, "a fraction from 0 to 1");
        m.dissolve = transparency ? 1.0f - v : v;
    }

    MtlTextureMap texture_map(std::string_view keyword) {
        MtlTextureMap map;
        map.line = m_line;
        std::size_t next = 1;
        while (next < m_tokens.size() && m_tokens[next].size() > 1 &&
               m_tokens[next].front() == '-' && !parse_real(m_tokens[next])) {
            const std::string_view name = m_tokens[next];
            const auto option =
                std::find_if(kTextureOptions.begin(), kTextureOptions.end(),
                             [&](const TextureOption& o) { return o.name == name; });
            if (option == kTextureOptions.end()) {
                fail(fmt::format("'{}' has the unknown option '{}'", keyword, name));
            }
            ++next;
            std::vector<float> values;
            while (next < m_tokens.size() && values.size() < option->max_values &&
                   (option->numeric ? parse_real(m_tokens[next]).has_value()
                                    : values.size() < option->min_values)) {
                values.push_back(option->numeric ? value(keyword, m_tokens[next]) : 0.0f);
                ++next;
            }
            if (values.size() < option->min_values) {
                fail(fmt::format("'{}' option '{}' needs {} value{}", keyword, name,
                                 option->min_values, option->min_values == 1 ? "" : "s"));
            }
            if (name == "-s" || name == "-o") {
                const Vec2f uv(values[0],
                               values.size() > 1 ? values[1] : (name == "-s" ? 1.0f : 0.0f));
                (name == "-s" ? map.scale : map.offset) = uv;
            } else {
                warn_once(
                    fmt::format("{} {}", keyword, name),
                    fmt::format("'{}' option '{}' is not supported and is ignored", keyword, name));
            }
        }
        if (next == m_tokens.size()) {
            fail(fmt::format("'{}' without a texture file", keyword));
        }
        // The file is the rest of the line: names may hold spaces.
        const std::string_view rest =
            m_rest.substr(static_cast<std::size_t>(m_tokens[next].data() - m_rest.data()));
        const fs::path named{std::string(mesh_io::trim(rest))};
        map.file = named.is_absolute() ? named : m_file.parent_path() / named;
        std::error_code ec;
        if (!fs::is_regular_file(map.file, ec)) {
            fail(fmt::format("'{}' texture '{}' not found (looked for {})", keyword, named.string(),
                             map.file.string()));
        }
        map.file = fs::weakly_canonical(map.file, ec);
        return map;
    }

    const fs::path& m_file;
    const MtlWarning& m_warn;
    MtlLibrary m_library;
    std::vector<std::string_view> m_tokens;
    std::string_view m_rest;  ///< The statement after its keyword.
    std::size_t m_line = 0;
    std::map<std::string, std::size_t> m_names;
    std::set<std::string> m_warned;
};

}  // namespace

const MtlMaterial* MtlLibrary::find(std::string_view name) const {
    const auto it = std::find_if(materials.begin(), materials.end(),
                                 [&](const MtlMaterial& m) { return m.name == name; });
    return it == materials.end() ? nullptr : &*it;
}

MtlLibrary parse_mtl(const fs::path& file, std::string_view text, const MtlWarning& warn) {
    return MtlParser(file, warn).run(text);
}

MtlLibrary read_mtl(const fs::path& file, const MtlWarning& warn) {
    return parse_mtl(file, mesh_io::read_whole_file(file), warn);
}

}  // namespace mrt
