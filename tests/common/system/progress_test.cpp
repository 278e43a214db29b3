// The progress bar: silent off a terminal, rate-limited and thread-safe on one.

#include "common/system/progress.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

namespace {

TEST(ProgressTest, QuietOrNonTerminalIsSilent) {
    ::testing::internal::CaptureStderr();
    {
        mrt::Progress quiet("quiet", 100, true);
        EXPECT_FALSE(quiet.enabled());
        mrt::Progress redirected("redirected", 1000);
        EXPECT_FALSE(redirected.enabled());  // stderr is a file while captured
        tbb::parallel_for(0, 1000, [&](int) {
            quiet.advance();
            redirected.advance();
        });
        redirected.finish();
    }
    EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
}

/// Runs `body` with stderr connected to a pseudo-terminal and returns what it printed.
template <typename Body>
std::string run_on_terminal(Body body, bool& available) {
    const int master = ::posix_openpt(O_RDWR | O_NOCTTY);
    available = master >= 0 && ::grantpt(master) == 0 && ::unlockpt(master) == 0;
    const char* slave_name = available ? ::ptsname(master) : nullptr;
    const int slave = slave_name != nullptr ? ::open(slave_name, O_RDWR | O_NOCTTY) : -1;
    available = available && slave >= 0;
    std::string output;
    if (available) {
        std::fflush(stderr);
        const int saved = ::dup(STDERR_FILENO);
        ::dup2(slave, STDERR_FILENO);
        body();
        std::fflush(stderr);
        ::dup2(saved, STDERR_FILENO);
        ::close(saved);
        ::fcntl(master, F_SETFL, ::fcntl(master, F_GETFL) | O_NONBLOCK);
        char buffer[4096];
        for (;;) {
            const ssize_t n = ::read(master, buffer, sizeof buffer);
            if (n <= 0) {
                break;
            }
            output.append(buffer, static_cast<std::size_t>(n));
        }
    }
    if (slave >= 0) {
        ::close(slave);
    }
    if (master >= 0) {
        ::close(master);
    }
    return output;
}

TEST(ProgressTest, TerminalBarIsRateLimitedAndEndsAtHundredPercentOnce) {
    double seconds = 0.0;
    bool available = false;
    const std::string out = run_on_terminal(
        [&] {
            const auto start = std::chrono::steady_clock::now();
            mrt::Progress progress("render", 400);
            EXPECT_TRUE(progress.enabled());
            tbb::parallel_for(0, 400, [&](int) {
                std::this_thread::sleep_for(std::chrono::milliseconds(2));
                progress.advance();
            });
            progress.finish();
            progress.finish();
            seconds =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        },
        available);
    if (!available) {
        GTEST_SKIP() << "no pseudo-terminal available";
    }
    // The terminal turns "\n" into "\r\n"; every other "\r" starts a redraw.
    const auto newlines = std::count(out.begin(), out.end(), '\n');
    const auto redraws = std::count(out.begin(), out.end(), '\r') - newlines;
    EXPECT_EQ(newlines, 1) << out;
    EXPECT_GE(redraws, 2) << out;  // the first frame and the final one
    EXPECT_LE(static_cast<double>(redraws), 3.0 + seconds * 10.0) << out;
    EXPECT_EQ(out.rfind("\rrender [", 0), 0U) << out;
    const std::string last = out.substr(out.rfind("\rrender"));
    EXPECT_NE(last.find("[" + std::string(30, '#') + "] 100%"), std::string::npos) << out;
    EXPECT_EQ(last.find("eta"), std::string::npos) << out;
    EXPECT_EQ(out.substr(out.size() - 2), "\r\n");
}

}  // namespace
