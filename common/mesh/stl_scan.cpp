// STL. OpenMesh welds the three corners of every facet by exact position, which is what makes
// the result indexed; it treats a file as binary when its size matches the facet count in the
// header. The scan checks every corner coordinate, naming the facet.

#include "common/mesh/format_scan.h"
#include "common/system/error.h"

#include <fmt/format.h>

#include <bit>

namespace mrt::mesh_io {

namespace fs = std::filesystem;

StlScan scan_stl(const fs::path& file, std::string_view text) {
    StlScan scan;
    if (text.size() >= 84) {
        const std::uint32_t count = load_little_endian_u32(text.data() + 80);
        if (84 + 50 * static_cast<std::uint64_t>(count) == text.size()) {
            scan.facet_count = count;
            for (std::size_t f = 0; f < count; ++f) {
                for (std::size_t c = 0; c < 9; ++c) {
                    const float v = std::bit_cast<float>(
                        load_little_endian_u32(text.data() + 84 + 50 * f + 12 + 4 * c));
                    if (!std::isfinite(v)) {
                        throw Error(file, fmt::format("facet {}", f),
                                    fmt::format("corner {} has a non-finite coordinate", c / 3));
                    }
                }
            }
            return scan;
        }
    }
    TokenCursor tokens(text, 1);
    const std::optional<std::string_view> first = tokens.next();
    if (!first || *first != "solid") {
        throw Error(file, "",
                    "not an STL file (neither a binary STL of matching size nor ASCII starting "
                    "with 'solid')");
    }
    while (const std::optional<std::string_view> token = tokens.next()) {
        if (*token == "facet") {
            ++scan.facet_count;
        } else if (*token == "vertex") {
            for (int i = 0; i < 3; ++i) {
                const std::optional<std::string_view> number = tokens.next();
                const std::optional<double> value =
                    number ? parse_real(*number) : std::optional<double>();
                if (!value || !finite_as_float(*value)) {
                    throw Error(file, fmt::format("line {}", tokens.line()),
                                fmt::format("facet {}: '{}' is not a finite coordinate",
                                            scan.facet_count == 0 ? 0 : scan.facet_count - 1,
                                            number.value_or("")));
                }
            }
        }
    }
    return scan;
}

}  // namespace mrt::mesh_io
