#include "common/system/atomic_file.h"

#include "common/system/error.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <system_error>

namespace mrt {

void check_output_file(const std::filesystem::path& file, const std::string& what) {
    const auto refuse = [&](const std::string& reason) {
        return Error(file, "", fmt::format("cannot write the {}: {}", what, reason));
    };
    std::error_code ec;
    if (std::filesystem::is_directory(file, ec)) {
        throw refuse("is a directory");
    }
    const std::filesystem::path dir =
        file.parent_path().empty() ? std::filesystem::path(".") : file.parent_path();
    if (!std::filesystem::exists(dir, ec)) {
        throw refuse(fmt::format("directory '{}' does not exist", dir.string()));
    }
    if (!std::filesystem::is_directory(dir, ec)) {
        throw refuse(fmt::format("'{}' is not a directory", dir.string()));
    }
    // Creating the temporary needs write and search permission on the directory.
    if (::access(dir.c_str(), W_OK | X_OK) != 0) {
        throw refuse(fmt::format("directory '{}' is not writable", dir.string()));
    }
}

void write_file_atomically(const std::filesystem::path& file, const std::string& contents,
                           const std::string& what) {
    // Unique per process and call, so concurrent writers never share a temporary.
    static std::atomic<unsigned> counter{0};
    const std::filesystem::path temporary =
        file.parent_path() / fmt::format(".{}.{}-{}.tmp", file.filename().string(),
                                         static_cast<long>(::getpid()), counter.fetch_add(1));
    bool written = false;
    {
        std::ofstream out(temporary, std::ios::binary);
        if (out) {
            out << contents;
            out.flush();
            written = static_cast<bool>(out);
        }
    }
    const int write_errno = errno;
    std::error_code ec;
    if (!written) {
        std::filesystem::remove(temporary, ec);
        throw Error(file, "",
                    fmt::format("cannot write the {}: {}", what, std::strerror(write_errno)));
    }
    std::filesystem::rename(temporary, file, ec);
    if (ec) {
        std::error_code ignored;
        std::filesystem::remove(temporary, ignored);
        throw Error(file, "", fmt::format("cannot write the {}: {}", what, ec.message()));
    }
}

namespace {

/// Writes all of `data` to `fd`, through partial writes and interruptions; false with errno set
/// on failure.
bool write_all(int fd, std::span<const std::byte> data) {
    while (!data.empty()) {
        const ssize_t n = ::write(fd, data.data(), data.size());
        if (n < 0) {
            if (errno == EINTR) {
                continue;
            }
            return false;
        }
        data = data.subspan(static_cast<std::size_t>(n));
    }
    return true;
}

}  // namespace

void write_file_atomically(const std::filesystem::path& file,
                           std::span<const std::span<const std::byte>> pieces,
                           const std::string& what) {
    const auto failure = [&](int error) {
        return Error(file, "", fmt::format("cannot write the {}: {}", what, std::strerror(error)));
    };
    // O_EXCL makes the temporary ours alone, even against another process that reuses our pid
    // in the name (a container) or a stale temporary from a killed run.
    static std::atomic<unsigned> counter{0};
    std::filesystem::path temporary;
    int fd = -1;
    for (int attempt = 0; attempt < 100 && fd < 0; ++attempt) {
        temporary =
            file.parent_path() / fmt::format(".{}.{}-{}.tmp", file.filename().string(),
                                             static_cast<long>(::getpid()), counter.fetch_add(1));
        fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd < 0 && errno != EEXIST) {
            throw failure(errno);
        }
    }
    if (fd < 0) {
        throw failure(EEXIST);
    }
    const auto discard = [&](int error) {
        std::error_code ignored;
        std::filesystem::remove(temporary, ignored);
        return failure(error);
    };
    for (const std::span<const std::byte> piece : pieces) {
        if (!write_all(fd, piece)) {
            const int error = errno;
            ::close(fd);
            throw discard(error);
        }
    }
    // close() reports deferred write errors (NFS, quotas), so its result counts too.
    if (::fsync(fd) != 0) {
        const int error = errno;
        ::close(fd);
        throw discard(error);
    }
    if (::close(fd) != 0) {
        throw discard(errno);
    }
    if (::rename(temporary.c_str(), file.c_str()) != 0) {
        throw discard(errno);
    }
}

}  // namespace mrt
