#pragma once
// Checks of internal invariants: a condition whose failure means a bug in this program (an index
// out of range, a weight that is not finite, a vector that should be unit length, fragments out
// of order), never bad input. Input a user can get wrong is reported as an mrt::Error
// (common/system/error.h), with the file and the place in it; a failed check names the source
// line and the condition, then aborts, so a debugger or a core dump holds the state that broke it.
//
// MRT_CHECK is always on: use it where a check costs nothing beside the work around it (once per
// render, per file, per node built). MRT_DCHECK is compiled only without NDEBUG (Debug builds):
// use it in per-ray and per-point loops, where a release build cannot afford the branch.

namespace mrt::detail {

/// Prints "FILE:LINE: check failed: CONDITION" to stderr and aborts. Out of line and cold, so
/// that a check adds one predictable branch to the code it guards.
[[noreturn]] [[gnu::cold]] [[gnu::noinline]] void check_failed(const char* file, int line,
                                                               const char* condition);

}  // namespace mrt::detail

#define MRT_CHECK(condition)            \
    ((condition) ? static_cast<void>(0) \
                 : ::mrt::detail::check_failed(__FILE__, __LINE__, #condition))

#ifdef NDEBUG
// Not evaluated, but still compiled: a check cannot rot in release-only builds, and the variables
// it reads do not become unused.
#define MRT_DCHECK(condition) static_cast<void>(sizeof(static_cast<bool>(condition)))
#else
#define MRT_DCHECK(condition) MRT_CHECK(condition)
#endif
