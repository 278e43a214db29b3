#include "common/system/progress.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <utility>

namespace mrt {

namespace {

constexpr std::int64_t kRedrawIntervalNs = 100'000'000;
constexpr int kBarWidth = 30;

std::string format_duration(double seconds) {
    if (seconds < 60.0) {
        return fmt::format("{:.1f} s", seconds);
    }
    const auto whole = static_cast<long long>(seconds);
    if (whole < 3600) {
        return fmt::format("{}m {:02}s", whole / 60, whole % 60);
    }
    return fmt::format("{}h {:02}m", whole / 3600, (whole / 60) % 60);
}

}  // namespace

Progress::Progress(std::string label, std::uint64_t total, bool quiet)
    : m_label(std::move(label)),
      m_total(total),
      m_enabled(!quiet && ::isatty(STDERR_FILENO) == 1),
      m_start(std::chrono::steady_clock::now()) {
    if (m_enabled) {
        const std::lock_guard lock(m_draw_mutex);
        draw(0);
    }
}

Progress::~Progress() {
    finish();
}

void Progress::advance(std::uint64_t units) {
    const std::uint64_t done = m_done.fetch_add(units, std::memory_order_relaxed) + units;
    if (!m_enabled) {
        return;
    }
    const std::int64_t now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                                 std::chrono::steady_clock::now() - m_start)
                                 .count();
    std::int64_t last = m_last_draw_ns.load(std::memory_order_relaxed);
    if (now - last < kRedrawIntervalNs) {
        return;
    }
    // Only the thread that wins the exchange draws; the others go straight back to work.
    if (!m_last_draw_ns.compare_exchange_strong(last, now, std::memory_order_relaxed)) {
        return;
    }
    // try_lock: a worker never waits behind finish() or a slow terminal.
    std::unique_lock lock(m_draw_mutex, std::try_to_lock);
    if (lock.owns_lock() && !m_finished) {
        draw(done);
    }
}

void Progress::finish() {
    const std::lock_guard lock(m_draw_mutex);
    if (m_finished) {
        return;
    }
    m_finished = true;
    if (m_enabled) {
        draw(m_total);
        std::fputc('\n', stderr);
        std::fflush(stderr);
    }
}

void Progress::draw(std::uint64_t done) {
    const double fraction =
        m_total == 0 ? 1.0
                     : static_cast<double>(std::min(done, m_total)) / static_cast<double>(m_total);
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
    const int filled = std::clamp(static_cast<int>(fraction * kBarWidth), 0, kBarWidth);
    const auto percent = static_cast<int>(fraction * 100.0);

    std::string line = fmt::format("\r{} [{}{}]{:>4}%  {}", m_label,
                                   std::string(static_cast<std::size_t>(filled), '#'),
                                   std::string(static_cast<std::size_t>(kBarWidth - filled), '.'),
                                   percent, format_duration(elapsed));
    if (fraction > 0.0 && fraction < 1.0) {
        line += "  eta " + format_duration(elapsed * (1.0 - fraction) / fraction);
    }
    // Erase what a longer previous line left behind (the eta disappears at 100 %).
    line += "\x1b[K";
    std::fputs(line.c_str(), stderr);
    std::fflush(stderr);
}

}  // namespace mrt
