#pragma once
// Progress bar on stderr when stderr is a terminal; silent otherwise (and when quiet).
// Thread-safe: advance() may be called from worker threads.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace mrt {

class Progress {
  public:
    /// `total` units of work under the label `label`.
    Progress(std::string label, std::uint64_t total, bool quiet = false);
    ~Progress();
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;

    void advance(std::uint64_t units = 1);
    /// Draws 100 % and ends the line (also done by the destructor).
    void finish();

    /// Units advanced so far (counted whether or not a bar is drawn).
    std::uint64_t done() const { return m_done.load(std::memory_order_relaxed); }

    /// Whether a bar would be drawn (stderr is a terminal and not quiet).
    bool enabled() const { return m_enabled; }

  private:
    void draw(std::uint64_t done);

    std::string m_label;
    std::uint64_t m_total;
    bool m_enabled;
    bool m_finished = false;
    std::atomic<std::uint64_t> m_done{0};
    std::atomic<std::int64_t> m_last_draw_ns{0};
    std::chrono::steady_clock::time_point m_start;
    std::mutex m_draw_mutex;
};

}  // namespace mrt
