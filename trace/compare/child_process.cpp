#include "trace/compare/child_process.h"

#include "common/system/error.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <poll.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <ostream>
#include <system_error>

extern char** environ;

namespace mrt {

namespace {

constexpr std::size_t kMaxCaptured = std::size_t{1} << 20;

/// A file descriptor closed when it goes out of scope.
class FileDescriptor {
  public:
    FileDescriptor() = default;
    explicit FileDescriptor(int fd) : m_fd(fd) {}
    ~FileDescriptor() { reset(); }
    FileDescriptor(const FileDescriptor&) = delete;
    FileDescriptor& operator=(const FileDescriptor&) = delete;

    int get() const { return m_fd; }
    void reset(int fd = -1) {
        if (m_fd >= 0) {
            ::close(m_fd);
        }
        m_fd = fd;
    }

  private:
    int m_fd = -1;
};

/// A pipe whose ends are close-on-exec (the child receives copies through dup2 only).
struct Pipe {
    FileDescriptor read;
    FileDescriptor write;
};

void open_pipe(Pipe& p, const std::filesystem::path& program) {
    std::array<int, 2> fds{};
    if (::pipe2(fds.data(), O_CLOEXEC) != 0) {
        throw Error(program, "", fmt::format("cannot run: pipe failed: {}", std::strerror(errno)));
    }
    p.read.reset(fds[0]);
    p.write.reset(fds[1]);
}

/// posix_spawn's file actions, destroyed with the scope.
class SpawnActions {
  public:
    SpawnActions() { ::posix_spawn_file_actions_init(&m_actions); }
    ~SpawnActions() { ::posix_spawn_file_actions_destroy(&m_actions); }
    SpawnActions(const SpawnActions&) = delete;
    SpawnActions& operator=(const SpawnActions&) = delete;
    posix_spawn_file_actions_t* get() { return &m_actions; }

  private:
    posix_spawn_file_actions_t m_actions{};
};

void append_bounded(std::string& to, const char* data, std::size_t size) {
    to.append(data, size);
    if (to.size() > 2 * kMaxCaptured) {
        to.erase(0, to.size() - kMaxCaptured);
    }
}

/// Reads both pipes until the child has closed them (on exit).
void drain(FileDescriptor& out_fd, FileDescriptor& err_fd, ProcessResult& result) {
    std::array<char, 65536> buffer{};
    while (out_fd.get() >= 0 || err_fd.get() >= 0) {
        std::array<pollfd, 2> polled{};
        polled[0] = {out_fd.get(), POLLIN, 0};
        polled[1] = {err_fd.get(), POLLIN, 0};
        if (::poll(polled.data(), polled.size(), -1) < 0) {
            if (errno == EINTR) {
                continue;
            }
            return;
        }
        for (std::size_t i = 0; i < polled.size(); ++i) {
            if (polled[i].fd < 0 || polled[i].revents == 0) {
                continue;
            }
            FileDescriptor& fd = i == 0 ? out_fd : err_fd;
            const ssize_t n = ::read(fd.get(), buffer.data(), buffer.size());
            if (n > 0) {
                append_bounded(i == 0 ? result.out : result.err, buffer.data(),
                               static_cast<std::size_t>(n));
            } else if (n == 0 || errno != EINTR) {
                fd.reset();
            }
        }
    }
    if (result.out.size() > kMaxCaptured) {
        result.out.erase(0, result.out.size() - kMaxCaptured);
    }
    if (result.err.size() > kMaxCaptured) {
        result.err.erase(0, result.err.size() - kMaxCaptured);
    }
}

}  // namespace

ProcessResult run_process(const std::filesystem::path& program,
                          const std::vector<std::string>& arguments) {
    std::vector<std::string> argv_strings;
    argv_strings.reserve(arguments.size() + 1);
    argv_strings.push_back(program.string());
    argv_strings.insert(argv_strings.end(), arguments.begin(), arguments.end());
    std::vector<char*> argv;
    for (std::string& s : argv_strings) {
        argv.push_back(s.data());
    }
    argv.push_back(nullptr);

    Pipe out;
    Pipe err;
    open_pipe(out, program);
    open_pipe(err, program);
    SpawnActions actions;
    ::posix_spawn_file_actions_addopen(actions.get(), STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    ::posix_spawn_file_actions_adddup2(actions.get(), out.write.get(), STDOUT_FILENO);
    ::posix_spawn_file_actions_adddup2(actions.get(), err.write.get(), STDERR_FILENO);

    const auto start = std::chrono::steady_clock::now();
    pid_t pid = 0;
    // glibc's posix_spawn reports a failed exec (missing file, no permission) as its result.
    const int spawn_error =
        ::posix_spawn(&pid, program.c_str(), actions.get(), nullptr, argv.data(), environ);
    if (spawn_error != 0) {
        throw Error(program, "", fmt::format("cannot run: {}", std::strerror(spawn_error)));
    }
    // Only the child holds the write ends now, so the reads end when it exits.
    out.write.reset();
    err.write.reset();

    ProcessResult result;
    drain(out.read, err.read, result);
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0) {
        if (errno != EINTR) {
            throw Error(program, "",
                        fmt::format("cannot wait for the child: {}", std::strerror(errno)));
        }
    }
    result.wall_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (WIFEXITED(status)) {
        result.exit_code = WEXITSTATUS(status);
    } else if (WIFSIGNALED(status)) {
        result.signal = WTERMSIG(status);
    }
    return result;
}

std::string describe_exit(const ProcessResult& result) {
    if (result.signal != 0) {
        return fmt::format("killed by signal {} ({})", result.signal, ::strsignal(result.signal));
    }
    return fmt::format("exit status {}", result.exit_code);
}

std::string last_line(const std::string& text) {
    std::string::size_type end = text.find_last_not_of(" \t\r\n");
    if (end == std::string::npos) {
        return "";
    }
    const std::string::size_type newline = text.find_last_of('\n', end);
    const std::string::size_type begin = newline == std::string::npos ? 0 : newline + 1;
    return text.substr(begin, end + 1 - begin);
}

std::ostream& operator<<(std::ostream& os, const ProcessResult& r) {
    return os << "ProcessResult{" << describe_exit(r) << ", " << r.wall_seconds << " s, stdout "
              << r.out.size() << " bytes, stderr \"" << last_line(r.err) << "\"}";
}

}  // namespace mrt
