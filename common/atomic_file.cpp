#include "common/atomic_file.h"

#include "common/error.h"

#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <system_error>

namespace mrt {

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

}  // namespace mrt
