#pragma once
// Wall-clock timing of the tools' phases (monotonic: immune to clock adjustments).

#include <chrono>

namespace mrt {

using Clock = std::chrono::steady_clock;

/// Seconds elapsed since `start`.
inline double seconds_since(Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace mrt
