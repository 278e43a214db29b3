#pragma once
// Small helpers shared by the test suites.

#include "common/error.h"

#include <string>

namespace mrt::testing {

/// The message of the mrt::Error that `f()` throws, or "(no error thrown)".
template <typename F>
std::string error_message(const F& f) {
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "(no error thrown)";
}

}  // namespace mrt::testing
