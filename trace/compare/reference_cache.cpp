#include "trace/compare/reference_cache.h"

#include "common/system/atomic_file.h"
#include "common/system/error.h"
#include "trace/render/pixel_filter.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <array>
#include <fstream>
#include <ostream>

namespace mrt {

namespace {

using nlohmann::json;

json optional_json(const std::optional<int>& v) {
    return v ? json(*v) : json(nullptr);
}

json optional_json(const std::optional<double>& v) {
    return v ? json(*v) : json(nullptr);
}

json key_json(const ReferenceKey& key) {
    return {{"scene", key.scene},
            {"scene_hash", key.scene_hash},
            {"width", optional_json(key.width)},
            {"height", optional_json(key.height)},
            {"filter", key.filter},
            {"texture_filter", key.texture_filter},
            {"spp", key.spp},
            {"seed", key.seed}};
}

/// The entry `name` of `record` as T, empty when missing or null. Throws on another type.
template <typename T>
std::optional<T> optional_entry(const std::filesystem::path& file, const json& record,
                                const char* name) {
    const auto it = record.find(name);
    if (it == record.end() || it->is_null()) {
        return std::nullopt;
    }
    if (!it->is_number()) {
        throw Error(file, fmt::format("/{}", name), "expected a number or null");
    }
    return it->get<T>();
}

json parse_json_file(const std::filesystem::path& file) {
    std::ifstream in(file);
    if (!in) {
        throw Error(file, "", "cannot read the reference record");
    }
    try {
        return json::parse(in);
    } catch (const json::parse_error& e) {
        throw Error(file, fmt::format("byte {}", e.byte), "not valid JSON");
    }
}

}  // namespace

std::string scene_file_hash(const std::filesystem::path& scene) {
    std::ifstream in(scene, std::ios::binary);
    if (!in) {
        throw Error(scene, "", "cannot read the scene file");
    }
    std::uint64_t hash = 0xcbf29ce484222325ull;
    std::array<char, 65536> buffer{};
    while (in.read(buffer.data(), buffer.size()) || in.gcount() > 0) {
        const auto n = static_cast<std::size_t>(in.gcount());
        for (std::size_t i = 0; i < n; ++i) {
            hash ^= static_cast<unsigned char>(buffer[i]);
            hash *= 0x100000001b3ull;
        }
    }
    if (in.bad()) {
        throw Error(scene, "", "cannot read the scene file");
    }
    return fmt::format("{:016x}", hash);
}

std::string canonical_filter(const std::string& filter) {
    const PixelFilter f = parse_pixel_filter(filter);
    if (f.kind == PixelFilter::Kind::Box) {
        return "box";
    }
    return fmt::format("gaussian:{}", f.sigma);
}

std::optional<ReferenceInfo> cached_reference_info(const std::filesystem::path& record,
                                                   const ReferenceKey& key) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(record, ec)) {
        return std::nullopt;
    }
    try {
        const json j = parse_json_file(record);
        if (!j.is_object() || !j.contains("key") || j["key"] != key_json(key)) {
            return std::nullopt;
        }
        return read_reference_info(record);
    } catch (const Error&) {
        // A damaged record only costs a new render.
        return std::nullopt;
    }
}

void write_reference_record(const std::filesystem::path& record, const ReferenceKey& key,
                            const ReferenceInfo& info) {
    const json j = {{"key", key_json(key)},
                    {"spp", optional_json(info.spp)},
                    {"seconds", optional_json(info.seconds)},
                    {"std_error", optional_json(info.std_error)}};
    write_file_atomically(record, j.dump(2) + "\n", "reference record");
}

ReferenceInfo read_reference_info(const std::filesystem::path& record) {
    const json j = parse_json_file(record);
    if (!j.is_object()) {
        throw Error(record, "", "expected a JSON object with spp, seconds and std_error");
    }
    ReferenceInfo info;
    info.spp = optional_entry<int>(record, j, "spp");
    info.seconds = optional_entry<double>(record, j, "seconds");
    info.std_error = optional_entry<double>(record, j, "std_error");
    return info;
}

std::ostream& operator<<(std::ostream& os, const ReferenceKey& k) {
    return os << "ReferenceKey" << key_json(k).dump();
}

}  // namespace mrt
