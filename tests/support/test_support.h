#pragma once
// Small helpers shared by the test suites.

#include "common/image/image.h"
#include "common/scene/scene.h"
#include "common/scene_io/data_path.h"
#include "common/system/error.h"
#include "trace/render/render.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <string>
#include <string_view>
#include <system_error>

namespace mrt::testing {

/// Whether `part` occurs in `text`.
inline bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

/// Writes `text` to `file` as it is (binary), replacing it.
inline void write_file(const std::filesystem::path& file, const std::string& text) {
    std::ofstream(file, std::ios::binary) << text;
}

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

/// A data file (e.g. "meshes/stanford-bunny.obj") on the data search path; run by hand rather
/// than through ctest MRT_DATA may be unset, so the build's own list (MRT_TEST_DATA_DIRS, when
/// the suite defines it) is tried too.
inline std::optional<std::filesystem::path> find_data_file(const std::string& name) {
    if (auto found = resolve_data_file(name, {})) {
        return found;
    }
#ifdef MRT_TEST_DATA_DIRS
    std::string_view dirs = MRT_TEST_DATA_DIRS;
    while (!dirs.empty()) {
        const std::size_t colon = dirs.find(':');
        const std::filesystem::path candidate = std::filesystem::path(dirs.substr(0, colon)) / name;
        if (!dirs.substr(0, colon).empty() && std::filesystem::is_regular_file(candidate)) {
            return candidate;
        }
        dirs = colon == std::string_view::npos ? std::string_view() : dirs.substr(colon + 1);
    }
#endif
    return std::nullopt;
}

/// Angle between two directions, in double, accurate for tiny angles and for vectors that are
/// unit only to float precision (acos of their dot product would be neither).
inline double angle_between(const Vec3d& a, const Vec3d& b) {
    return std::atan2(a.cross(b).norm(), a.dot(b));
}

/// A uniformly distributed unit vector (a normalised Gaussian triple).
inline Vec3d random_direction(std::mt19937_64& rng) {
    std::normal_distribution<double> gauss;
    Vec3d v;
    do {
        v = Vec3d(gauss(rng), gauss(rng), gauss(rng));
    } while (v.norm() < 1e-6);
    return v.normalized();
}

/// Copies `part`, rendered for `window` of a frame (RenderOptions::crop), into `frame`.
inline void paste(Image& frame, const Image& part, const PixelWindow& window) {
    ASSERT_EQ(part.width(), window.width());
    ASSERT_EQ(part.height(), window.height());
    for (int y = 0; y < part.height(); ++y) {
        for (int x = 0; x < part.width(); ++x) {
            frame.set(window.x0 + x, window.y0 + y, part.at(x, y));
        }
    }
}

/// The mean colour of an image's pixels.
inline Rgb mean_of(const Image& image) {
    Rgb sum = Rgb::Zero();
    for (int y = 0; y < image.height(); ++y) {
        for (int x = 0; x < image.width(); ++x) {
            sum += image.at(x, y);
        }
    }
    return sum / static_cast<float>(image.width() * image.height());
}

/// Whether two images hold the same floats, bit for bit (not within a tolerance).
inline bool same_bits(const Image& a, const Image& b) {
    return a.width() == b.width() && a.height() == b.height() &&
           std::memcmp(a.data().data(), b.data().data(), a.data().size() * sizeof(float)) == 0;
}

/// Render options for the scene camera's full image, without a progress bar.
inline RenderOptions camera_options(const Scene& scene) {
    RenderOptions options;
    options.width = scene.camera.width;
    options.height = scene.camera.height;
    options.quiet = true;
    return options;
}

/// A fresh directory for the running test, removed with the object. Named after the process
/// and the test, because ctest runs the tests of one suite as parallel processes.
class ScratchDirectory {
  public:
    explicit ScratchDirectory(const std::string& prefix) {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        m_path = std::filesystem::temp_directory_path() /
                 (prefix + "_" + std::to_string(::getpid()) + "_" +
                  (info != nullptr ? info->name() : "global"));
        std::filesystem::remove_all(m_path);
        std::filesystem::create_directories(m_path);
    }
    ~ScratchDirectory() {
        std::error_code ignored;
        std::filesystem::remove_all(m_path, ignored);
    }
    ScratchDirectory(const ScratchDirectory&) = delete;
    ScratchDirectory& operator=(const ScratchDirectory&) = delete;

    const std::filesystem::path& path() const { return m_path; }

  private:
    std::filesystem::path m_path;
};

}  // namespace mrt::testing
