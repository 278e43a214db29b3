#include "common/system/temporary_directory.h"

#include "common/system/error.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <climits>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <system_error>

namespace mrt {

namespace {

namespace fs = std::filesystem;

/// The signals a user or a scheduler ends a run with, and that a handler can still see.
constexpr std::array<int, 3> kCleanupSignals = {SIGINT, SIGTERM, SIGHUP};

/// The live directories, as a fixed table the signal handler can read without allocating or
/// locking: a slot's path is written while it is Claimed and read only once it is Ready.
enum SlotState : int { Free = 0, Claimed = 1, Ready = 2 };
struct Slot {
    std::atomic<int> state{Free};
    char path[PATH_MAX] = {};
};
static_assert(std::atomic<int>::is_always_lock_free, "the signal handler needs lock-free slots");
constexpr std::size_t kSlots = 32;
std::array<Slot, kSlots> g_slots;

/// The entries of a directory as the getdents64 system call returns them (linux_dirent64).
struct LinuxDirent64 {
    std::uint64_t d_ino;
    std::int64_t d_off;
    unsigned short d_reclen;
    unsigned char d_type;
    char d_name[1];
};

/// Removes the files of `path` and then the directory, with system calls only: no allocation,
/// no lock, nothing a signal handler may not call (opendir/readdir allocate, so the entries are
/// read with getdents64 itself).
void remove_directory_from_handler(const char* path) {
    const int fd = ::open(path, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd >= 0) {
        alignas(8) char buffer[4096];
        while (true) {
            const long n = ::syscall(SYS_getdents64, fd, buffer, sizeof(buffer));
            if (n <= 0) {
                break;
            }
            for (long at = 0; at < n;) {
                const auto* entry = reinterpret_cast<const LinuxDirent64*>(buffer + at);
                const char* name = entry->d_name;
                const bool dots =
                    name[0] == '.' && (name[1] == '\0' || (name[1] == '.' && name[2] == '\0'));
                if (!dots) {
                    ::unlinkat(fd, name, 0);
                }
                at += entry->d_reclen;
            }
        }
        ::close(fd);
    }
    ::rmdir(path);
}

extern "C" void remove_temporary_directories_and_die(int signal_number) {
    const int saved_errno = errno;
    for (Slot& slot : g_slots) {
        if (slot.state.load(std::memory_order_acquire) == Ready) {
            remove_directory_from_handler(slot.path);
        }
    }
    // Die of the same signal, as if there had been no handler: the parent (a shell, a farm's
    // scheduler) must see how the run ended. The signal is blocked until the handler returns.
    struct sigaction default_action {};
    default_action.sa_handler = SIG_DFL;
    sigemptyset(&default_action.sa_mask);
    ::sigaction(signal_number, &default_action, nullptr);
    ::raise(signal_number);
    errno = saved_errno;
}

/// Installs the handler for each cleanup signal whose disposition is still the default: a
/// signal the program or its parent ignores (nohup) or handles itself is left as it is.
void install_handlers_once() {
    static std::once_flag once;
    std::call_once(once, [] {
        for (const int signal_number : kCleanupSignals) {
            struct sigaction current {};
            if (::sigaction(signal_number, nullptr, &current) != 0 ||
                (current.sa_flags & SA_SIGINFO) != 0 || current.sa_handler != SIG_DFL) {
                continue;
            }
            struct sigaction action {};
            action.sa_handler = remove_temporary_directories_and_die;
            // Nothing else interrupts the cleanup.
            sigfillset(&action.sa_mask);
            ::sigaction(signal_number, &action, nullptr);
        }
    });
}

/// Claims a slot for `path`; -1 when the table is full (the destructor and the next run's
/// sweep still remove the directory).
int register_directory(const fs::path& path) {
    const std::string& text = path.native();
    if (text.size() >= PATH_MAX) {
        return -1;
    }
    for (std::size_t i = 0; i < kSlots; ++i) {
        int expected = Free;
        if (g_slots[i].state.compare_exchange_strong(expected, Claimed,
                                                     std::memory_order_acq_rel)) {
            std::memcpy(g_slots[i].path, text.c_str(), text.size() + 1);
            g_slots[i].state.store(Ready, std::memory_order_release);
            return static_cast<int>(i);
        }
    }
    return -1;
}

/// Blocks the cleanup signals in this thread for its lifetime, so that a directory is never on
/// disk without being in the table (between mkdtemp and registration) or the other way round.
class CleanupSignalsBlocked {
  public:
    CleanupSignalsBlocked() {
        sigset_t set;
        sigemptyset(&set);
        for (const int signal_number : kCleanupSignals) {
            sigaddset(&set, signal_number);
        }
        ::pthread_sigmask(SIG_BLOCK, &set, &m_previous);
    }
    ~CleanupSignalsBlocked() { ::pthread_sigmask(SIG_SETMASK, &m_previous, nullptr); }
    CleanupSignalsBlocked(const CleanupSignalsBlocked&) = delete;
    CleanupSignalsBlocked& operator=(const CleanupSignalsBlocked&) = delete;

  private:
    sigset_t m_previous;
};

/// The process id in a name `PREFIX-PID-REST`, or 0 when the name is not of that form.
pid_t owner_pid(const std::string& name, const std::string& prefix) {
    const std::string head = prefix + "-";
    if (name.compare(0, head.size(), head) != 0) {
        return 0;
    }
    const std::size_t digits_end = name.find('-', head.size());
    if (digits_end == std::string::npos || digits_end == head.size() ||
        digits_end - head.size() > 9) {
        return 0;
    }
    long pid = 0;
    for (std::size_t i = head.size(); i < digits_end; ++i) {
        if (name[i] < '0' || name[i] > '9') {
            return 0;
        }
        pid = pid * 10 + (name[i] - '0');
    }
    return static_cast<pid_t>(pid);
}

}  // namespace

std::size_t remove_stale_temporary_directories(const fs::path& parent, const std::string& prefix) {
    std::size_t removed = 0;
    std::error_code ec;
    for (fs::directory_iterator it(parent, ec), end; !ec && it != end; it.increment(ec)) {
        const pid_t pid = owner_pid(it->path().filename().string(), prefix);
        struct stat info {};
        if (pid <= 0 || pid == ::getpid() || ::lstat(it->path().c_str(), &info) != 0 ||
            !S_ISDIR(info.st_mode) || info.st_uid != ::geteuid()) {
            continue;
        }
        // ESRCH: no such process. EPERM means it exists (under another user): keep it.
        if (::kill(pid, 0) == 0 || errno != ESRCH) {
            continue;
        }
        std::error_code ignored;
        if (fs::remove_all(it->path(), ignored) > 0 && !ignored) {
            ++removed;
        }
    }
    return removed;
}

TemporaryDirectory::TemporaryDirectory(const std::string& prefix, const std::string& what) {
    std::error_code ec;
    const fs::path parent = fs::temp_directory_path(ec);
    if (ec) {
        throw Error(fmt::format("cannot find a temporary directory for {} ($TMPDIR): {}", what,
                                ec.message()));
    }
    remove_stale_temporary_directories(parent, prefix);
    install_handlers_once();
    const CleanupSignalsBlocked blocked;
    std::string pattern =
        (parent / fmt::format("{}-{}-XXXXXX", prefix, static_cast<long>(::getpid()))).string();
    if (::mkdtemp(pattern.data()) == nullptr) {
        throw Error(parent, "",
                    fmt::format("cannot create a directory for {}: {}", what,
                                std::generic_category().message(errno)));
    }
    m_path = pattern;
    m_slot = register_directory(m_path);
}

TemporaryDirectory::~TemporaryDirectory() {
    // Removed while still in the table: a signal arriving meanwhile finishes the removal.
    std::error_code ignored;
    fs::remove_all(m_path, ignored);
    if (m_slot >= 0) {
        g_slots[static_cast<std::size_t>(m_slot)].state.store(Free, std::memory_order_release);
    }
}

}  // namespace mrt
