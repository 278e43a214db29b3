#pragma once
// Private temporary directories that a run leaves behind under no circumstances it can see: the
// destructor removes one with its files; SIGINT, SIGTERM and SIGHUP remove every live one and
// then end the process by the same signal (so its exit status still says how it died); and the
// directories of runs nothing could clean up after (SIGKILL, a crash) are swept by the next run
// that creates one, recognised by the id of their process, which is part of their name.

#include <cstddef>
#include <filesystem>
#include <string>

namespace mrt {

/// A directory `$TMPDIR/PREFIX-PID-XXXXXX` (PID this process's id, XXXXXX random), removed with
/// its files by the destructor or by the signal handler described above. It must hold plain
/// files only (the handler removes no subdirectories).
class TemporaryDirectory {
  public:
    /// Creates the directory after sweeping the stale ones of the same prefix; `what` names its
    /// purpose in error messages ("mip-mapped textures"). Throws mrt::Error naming the parent
    /// directory and the system's reason when it cannot be created.
    TemporaryDirectory(const std::string& prefix, const std::string& what);
    ~TemporaryDirectory();
    TemporaryDirectory(const TemporaryDirectory&) = delete;
    TemporaryDirectory& operator=(const TemporaryDirectory&) = delete;

    const std::filesystem::path& path() const { return m_path; }

  private:
    std::filesystem::path m_path;
    int m_slot = -1;  ///< Its entry in the signal handler's table, or -1 if the table was full.
};

/// Removes the directories `parent/PREFIX-PID-*` of this user whose process PID no longer exists
/// and returns how many it removed. Directories of live processes, of other users and names not
/// of that form are left alone. (A process id reused since is taken as alive: the directory then
/// waits for a later sweep.)
std::size_t remove_stale_temporary_directories(const std::filesystem::path& parent,
                                               const std::string& prefix);

}  // namespace mrt
