#pragma once
// Libraries that print on the process's standard error themselves (libpng prints "libpng
// error: …" before OpenImageIO, which reports the same failure through its error string, turns
// it into a return value) would put a second line before the tool's one-line message. Their
// output is diverted for the duration of such a call and handed back only if the call succeeds.

#include <memory>
#include <string>

namespace mrt {

/// Diverts file descriptor 2 into an anonymous file from construction until finish() or
/// destruction. Process-wide (another thread's writes to stderr meanwhile are diverted too), so
/// captures are serialised and meant for short calls made before rendering starts.
class StderrCapture {
  public:
    StderrCapture();
    /// Restores stderr, discarding what was captured (the failure path: the caller's error
    /// message says what went wrong).
    ~StderrCapture();
    StderrCapture(const StderrCapture&) = delete;
    StderrCapture& operator=(const StderrCapture&) = delete;

    /// Restores stderr and returns what was written to it meanwhile.
    std::string finish();

    /// Restores stderr and writes what was captured to it, as if nothing had been diverted (the
    /// success path: a library's warnings stay visible).
    void pass_through();

  private:
    struct State;
    std::unique_ptr<State> m_state;
};

}  // namespace mrt
