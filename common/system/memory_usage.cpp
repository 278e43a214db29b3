#include "common/system/memory_usage.h"

#include <sys/resource.h>

namespace mrt {

std::uint64_t peak_rss_bytes() {
    rusage usage{};
    if (getrusage(RUSAGE_SELF, &usage) != 0) {
        return 0;
    }
    // Linux reports ru_maxrss in kibibytes.
    return static_cast<std::uint64_t>(usage.ru_maxrss) * 1024u;
}

}  // namespace mrt
