#include "common/system/check.h"

#include <cstdio>
#include <cstdlib>

namespace mrt::detail {

void check_failed(const char* file, int line, const char* condition) {
    // stdio rather than streams or fmt: the state that failed the check may be the allocator's
    // or a stream's, and the message has to get out before the abort.
    std::fprintf(stderr, "%s:%d: check failed: %s\n", file, line, condition);
    std::fflush(stderr);
    std::abort();
}

}  // namespace mrt::detail
