#include "common/scene_io/data_path.h"

#include <cstdlib>
#include <string_view>
#include <system_error>

namespace mrt {

namespace {

bool is_existing_file(const std::filesystem::path& path) {
    // The error_code overload: an unreadable directory on the way just means "not here".
    std::error_code error;
    return std::filesystem::is_regular_file(path, error);
}

std::filesystem::path absolute_normal(const std::filesystem::path& path) {
    std::error_code error;
    const std::filesystem::path absolute = std::filesystem::absolute(path, error);
    return (error ? path : absolute).lexically_normal();
}

}  // namespace

std::vector<std::filesystem::path> data_search_path() {
    std::vector<std::filesystem::path> directories;
    if (const char* env = std::getenv("MRT_DATA")) {
        std::string_view rest(env);
        while (!rest.empty()) {
            const auto colon = rest.find(':');
            const std::string_view entry = rest.substr(0, colon);
            // Empty entries ("a::b", a trailing ':') name no directory.
            if (!entry.empty()) {
                directories.emplace_back(entry);
            }
            rest = colon == std::string_view::npos ? std::string_view() : rest.substr(colon + 1);
        }
    }
    directories.emplace_back("../shared/data");
    directories.emplace_back("data");
    return directories;
}

std::vector<std::filesystem::path> data_file_candidates(
    const std::string& name, const std::filesystem::path& relative_to_dir) {
    const std::filesystem::path path(name);
    if (path.is_absolute()) {
        return {path};
    }
    // An empty directory (a scene file named without one) means the working directory.
    std::vector<std::filesystem::path> candidates{relative_to_dir / path};
    for (const auto& directory : data_search_path()) {
        candidates.push_back(directory / path);
    }
    return candidates;
}

std::optional<std::filesystem::path> resolve_data_file(
    const std::string& name, const std::filesystem::path& relative_to_dir) {
    if (name.empty()) {
        return std::nullopt;
    }
    for (const auto& candidate : data_file_candidates(name, relative_to_dir)) {
        if (is_existing_file(candidate)) {
            return absolute_normal(candidate);
        }
    }
    return std::nullopt;
}

}  // namespace mrt
