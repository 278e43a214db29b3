#pragma once
// How much memory this process has used, for the tools' statistics.

#include <cstdint>

namespace mrt {

/// Peak resident set size of this process so far, in bytes (0 if the system will not say).
std::uint64_t peak_rss_bytes();

}  // namespace mrt
