#include "trace/tools/render_stats.h"

#include "common/system/atomic_file.h"

#include <nlohmann/json.hpp>

#include <ostream>
#include <type_traits>

namespace mrt {

namespace {

template <class V>
inline constexpr bool is_optional_record = false;
template <HasFields V>
inline constexpr bool is_optional_record<std::optional<V>> = true;

template <HasFields T>
nlohmann::json record_json(const T& record);

template <class V>
nlohmann::json json_value(const V& value) {
    if constexpr (HasFields<V>) {
        return record_json(value);
    } else if constexpr (std::is_same_v<V, Method>) {
        return std::string(to_string(value));
    } else if constexpr (std::is_same_v<V, PixelWindow>) {
        return nlohmann::json::array({value.x0, value.y0, value.x1, value.y1});
    } else if constexpr (requires { value.has_value(); }) {
        return value ? json_value(*value) : nlohmann::json(nullptr);
    } else {
        return value;
    }
}

/// An object of the record's fields: absent values are null, an absent sub-record is left out.
template <HasFields T>
nlohmann::json record_json(const T& record) {
    nlohmann::json j = nlohmann::json::object();
    for_each_field(record, [&](std::string_view name, const auto& value) {
        if constexpr (is_optional_record<std::decay_t<decltype(value)>>) {
            if (!value) {
                return;
            }
        }
        j[std::string(name)] = json_value(value);
    });
    return j;
}

}  // namespace

double RenderStats::mean_spp() const {
    return width > 0 && height > 0
               ? static_cast<double>(samples) / (static_cast<double>(width) * height)
               : 0.0;
}

double RenderStats::rays_per_second() const {
    return render_seconds > 0.0 ? static_cast<double>(rays.total()) / render_seconds : 0.0;
}

std::ostream& operator<<(std::ostream& os, const RenderStats& s) {
    return print_fields(os, "RenderStats", s);
}

std::string render_stats_json(const RenderStats& stats) {
    return record_json(stats).dump(2) + "\n";
}

void write_render_stats(const std::filesystem::path& file, const RenderStats& stats) {
    write_file_atomically(file, render_stats_json(stats), "stats file");
}

}  // namespace mrt
