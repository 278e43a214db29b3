#pragma once
// Text files written whole or not at all: to a temporary name beside the target, then renamed
// into place, so a reader (or a killed run) never sees a half-written file under the real name.

#include <filesystem>
#include <string>

namespace mrt {

/// Writes `contents` to `file` atomically. `what` names the file's role in the error message
/// ("results file"). Throws mrt::Error naming the file; no temporary is left behind.
void write_file_atomically(const std::filesystem::path& file, const std::string& contents,
                           const std::string& what);

}  // namespace mrt
