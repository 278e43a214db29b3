#include "common/image/stderr_capture.h"

#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <mutex>
#include <string>

namespace mrt {

namespace {

/// One capture at a time: they all redirect the same descriptor.
std::recursive_mutex g_capture_mutex;

bool write_all(int fd, const std::string& text) {
    std::size_t done = 0;
    while (done < text.size()) {
        const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
        if (n < 0) {
            if (errno == EINTR) {
                continue;
            }
            return false;
        }
        done += static_cast<std::size_t>(n);
    }
    return true;
}

}  // namespace

struct StderrCapture::State {
    std::unique_lock<std::recursive_mutex> lock{g_capture_mutex};
    int saved = -1;    ///< The real stderr, while diverted; -1 when not diverted.
    int capture = -1;  ///< The anonymous file receiving it.

    /// Restores the real stderr and returns what the capture file received.
    std::string restore() {
        std::string text;
        if (saved < 0) {
            return text;
        }
        std::fflush(stderr);
        ::dup2(saved, STDERR_FILENO);
        ::close(saved);
        saved = -1;
        char buffer[4096];
        if (::lseek(capture, 0, SEEK_SET) == 0) {
            while (true) {
                const ssize_t n = ::read(capture, buffer, sizeof(buffer));
                if (n > 0) {
                    text.append(buffer, static_cast<std::size_t>(n));
                } else if (n < 0 && errno == EINTR) {
                    continue;
                } else {
                    break;
                }
            }
        }
        ::close(capture);
        capture = -1;
        return text;
    }
};

StderrCapture::StderrCapture() : m_state(std::make_unique<State>()) {
    std::fflush(stderr);
    m_state->capture = ::memfd_create("mrt-stderr", MFD_CLOEXEC);
    if (m_state->capture < 0) {
        // Nothing to divert into: the library's lines then reach stderr as they would anyway.
        return;
    }
    m_state->saved = ::dup(STDERR_FILENO);
    if (m_state->saved < 0 || ::dup2(m_state->capture, STDERR_FILENO) < 0) {
        if (m_state->saved >= 0) {
            ::close(m_state->saved);
            m_state->saved = -1;
        }
        ::close(m_state->capture);
        m_state->capture = -1;
    }
}

StderrCapture::~StderrCapture() {
    m_state->restore();
}

std::string StderrCapture::finish() {
    return m_state->restore();
}

void StderrCapture::pass_through() {
    const std::string text = m_state->restore();
    write_all(STDERR_FILENO, text);
}

}  // namespace mrt
