#pragma once
// Where scene files look for the files they name: first relative to the scene file, then along
// the data search path: the directories in $MRT_DATA (':'-separated), then ../shared/data and
// data/ relative to the working directory.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace mrt {

/// The search path in order (existing or not), from the environment.
std::vector<std::filesystem::path> data_search_path();

/// Resolves `name` (relative or absolute) as described above. Returns nothing when no candidate
/// exists.
std::optional<std::filesystem::path> resolve_data_file(
    const std::string& name, const std::filesystem::path& relative_to_dir);

}  // namespace mrt
