#pragma once
// Files written whole or not at all: to a temporary name beside the target, then renamed into
// place, so a reader (or a killed run) never sees a half-written file under the real name.

#include <cstddef>
#include <filesystem>
#include <span>
#include <string>

namespace mrt {

/// Checks, before any work is done, that `file` could be written atomically: it is not a
/// directory, and its directory exists and is writable (the temporary is created there). Throws
/// mrt::Error "FILE: cannot write the WHAT: REASON", `what` naming the file's role.
void check_output_file(const std::filesystem::path& file, const std::string& what);

/// Writes `contents` to `file` atomically. `what` names the file's role in the error message
/// ("results file"). Throws mrt::Error naming the file; no temporary is left behind.
void write_file_atomically(const std::filesystem::path& file, const std::string& contents,
                           const std::string& what);

/// Writes the concatenation of `pieces` to `file` atomically, as binary, without gathering them
/// into one buffer first (hierarchy files reach hundreds of megabytes). The data is flushed to
/// the disk (fsync) before the rename, so even a crash leaves the old file or the whole new one.
/// `what` names the file's role in the error message ("hierarchy file"). Throws mrt::Error
/// naming the file; no temporary is left behind and an existing `file` is unchanged.
void write_file_atomically(const std::filesystem::path& file,
                           std::span<const std::span<const std::byte>> pieces,
                           const std::string& what);

}  // namespace mrt
