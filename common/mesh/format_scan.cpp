// The parts of the format scans that are not one format's: choosing the format, reading text.

#include "common/mesh/format_scan.h"
#include "common/system/enum_names.h"
#include "common/system/error.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>
#include <iterator>
#include <system_error>

namespace mrt::mesh_io {

namespace fs = std::filesystem;

std::string read_whole_file(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) {
        throw Error(file, "", fmt::format("cannot be opened: {}", std::strerror(errno)));
    }
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) {
        throw Error(file, "", fmt::format("cannot be read: {}", std::strerror(errno)));
    }
    return bytes;
}

std::optional<Format> format_from_extension(const fs::path& file) {
    std::string ext = file.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext == ".obj") {
        return Format::obj;
    }
    if (ext == ".ply") {
        return Format::ply;
    }
    if (ext == ".off") {
        return Format::off;
    }
    if (ext == ".stl") {
        return Format::stl;
    }
    return std::nullopt;
}

std::string_view format_name(Format format) {
    static constexpr EnumNames<Format, 4> kNames{{{
        {Format::obj, "OBJ"},
        {Format::ply, "PLY"},
        {Format::off, "OFF"},
        {Format::stl, "STL"},
    }}};
    return kNames.name(format, "mesh");
}

std::string_view trim(std::string_view s) {
    while (!s.empty() && is_space(s.front())) {
        s.remove_prefix(1);
    }
    while (!s.empty() && is_space(s.back())) {
        s.remove_suffix(1);
    }
    return s;
}

void split_tokens(std::string_view line, std::vector<std::string_view>& tokens) {
    tokens.clear();
    std::size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && is_space(line[i])) {
            ++i;
        }
        const std::size_t start = i;
        while (i < line.size() && !is_space(line[i])) {
            ++i;
        }
        if (i > start) {
            tokens.push_back(line.substr(start, i - start));
        }
    }
}

std::optional<double> parse_real(std::string_view token) {
    if (!token.empty() && token.front() == '+') {
        token.remove_prefix(1);
    }
    if (token.empty()) {
        return std::nullopt;
    }
    double value = 0.0;
    const char* const end = token.data() + token.size();
    const auto [ptr, ec] = std::from_chars(token.data(), end, value);
    if (ptr != end) {
        return std::nullopt;
    }
    if (ec == std::errc::result_out_of_range) {
        // from_chars leaves the value alone on overflow and underflow alike; the exponent's sign
        // tells them apart.
        const std::size_t e = token.find_first_of("eE");
        const bool underflow =
            e != std::string_view::npos && e + 1 < token.size() && token[e + 1] == '-';
        const bool negative = token.front() == '-';
        if (underflow) {
            return negative ? -0.0 : 0.0;
        }
        return negative ? -std::numeric_limits<double>::infinity()
                        : std::numeric_limits<double>::infinity();
    }
    if (ec != std::errc()) {
        return std::nullopt;
    }
    return value;
}

std::optional<long long> parse_integer(std::string_view token) {
    if (!token.empty() && token.front() == '+') {
        token.remove_prefix(1);
    }
    long long value = 0;
    const char* const end = token.data() + token.size();
    const auto [ptr, ec] = std::from_chars(token.data(), end, value);
    if (token.empty() || ptr != end || ec != std::errc()) {
        return std::nullopt;
    }
    return value;
}

std::string format_number(double v) {
    return fmt::format("{}", v);
}

ScanResult scan_file(const fs::path& file, Format format, std::string_view bytes) {
    ScanResult scan;
    switch (format) {
        case Format::obj:
            scan.obj = scan_obj(file, bytes);
            scan.triangles = scan.obj->fan_triangles;
            scan.vertices = scan.obj->vertex_count;
            break;
        case Format::ply: {
            const PlyScan ply = scan_ply(file, bytes);
            scan.vertices = ply.vertex_count;
            scan.faces = ply.face_count;
            break;
        }
        case Format::off: {
            const OffScan off = scan_off(file, bytes);
            scan.vertices = off.vertex_count;
            scan.faces = off.face_count;
            break;
        }
        case Format::stl:
            scan.triangles = scan_stl(file, bytes).facet_count;
            break;
    }
    return scan;
}

}  // namespace mrt::mesh_io
