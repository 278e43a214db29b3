#pragma once
// Running another program as a child process: an argument vector, never a shell, so paths with
// spaces or quotes pass through unchanged. Its stdout and stderr are captured; stdin is
// /dev/null.

#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

namespace mrt {

/// How a child process ended and what it printed.
struct ProcessResult {
    int exit_code = -1;         ///< Exit status, or −1 when a signal ended it.
    int signal = 0;             ///< The signal that ended it, 0 when it exited.
    std::string out;            ///< Everything written to stdout (the last 1 MiB).
    std::string err;            ///< Everything written to stderr (the last 1 MiB).
    double wall_seconds = 0.0;  ///< From spawning to reaping the child, in seconds.

    bool succeeded() const { return signal == 0 && exit_code == 0; }
};

/// Runs `program` with `arguments` (argv[1...]; argv[0] is the program path) in this process's
/// environment and waits for it. Throws mrt::Error naming the program when it cannot be
/// started (missing, not executable); a child that runs and fails is reported in the result.
ProcessResult run_process(const std::filesystem::path& program,
                          const std::vector<std::string>& arguments);

/// "exit status 3" or "killed by signal 9 (Killed)".
std::string describe_exit(const ProcessResult& result);

/// The last non-blank line of `text`, without its line end ("" when there is none).
std::string last_line(const std::string& text);

std::ostream& operator<<(std::ostream& os, const ProcessResult& r);

}  // namespace mrt
