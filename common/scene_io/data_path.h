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

/// Where `name` is looked for, in order: itself if absolute, else relative to `relative_to_dir`
/// (empty: the working directory) and then in each directory of the search path.
std::vector<std::filesystem::path> data_file_candidates(
    const std::string& name, const std::filesystem::path& relative_to_dir);

/// Resolves `name` (relative or absolute) as described above: the first of its candidates that
/// exists, absolute. Returns nothing when none does.
std::optional<std::filesystem::path> resolve_data_file(
    const std::string& name, const std::filesystem::path& relative_to_dir);

}  // namespace mrt
