// A triangle's and a surfel's coverage mask against the Gaussian mass the cone weighs a
// triangle by today: what masks add per fragment (issue: sub-pixel coverage masks).
#include "trace/cone/cone_triangle.h"
#include "trace/cone/coverage_mask.h"

#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace {

using mrt::Mat2f;
using mrt::Vec2f;

/// Triangles with their vertices inside the clip circle, as the cone meets them.
std::vector<std::array<Vec2f, 3>> triangles() {
    std::mt19937 random(3);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::vector<std::array<Vec2f, 3>> out(1024);
    for (auto& t : out) {
        for (Vec2f& p : t) {
            const float r = 1.9f * std::sqrt(unit(random));
            const float a = 2.0f * std::numbers::pi_v<float> * unit(random);
            p = Vec2f(r * std::cos(a), r * std::sin(a));
        }
    }
    return out;
}

void BM_TriangleMask(benchmark::State& state) {
    const auto t = triangles();
    std::size_t i = 0;
    for (auto _ : state) {
        const auto& v = t[i++ & 1023];
        benchmark::DoNotOptimize(mrt::triangle_mask(v[0], v[1], v[2]));
    }
}
BENCHMARK(BM_TriangleMask);

void BM_GaussianTriangleMass(benchmark::State& state) {
    const auto t = triangles();
    std::size_t i = 0;
    for (auto _ : state) {
        const auto& v = t[i++ & 1023];
        benchmark::DoNotOptimize(mrt::gaussian_triangle_mass(v[0], v[1], v[2]));
    }
}
BENCHMARK(BM_GaussianTriangleMass);

/// A point's disc mask: the dispatched kernel, and the one-sample-at-a-time reference it
/// answers as.
void BM_EllipseMask(benchmark::State& state,
                    mrt::CoverageMask (*mask_of)(const Vec2f&, const Mat2f&, mrt::SamplePattern)) {
    const auto t = triangles();
    const Mat2f form{{4.0f, 1.0f}, {1.0f, 2.0f}};
    std::size_t i = 0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(mask_of(t[i++ & 1023][0], form, mrt::SamplePattern::Gaussian));
    }
}
BENCHMARK_CAPTURE(BM_EllipseMask, dispatched, &mrt::ellipse_mask);
BENCHMARK_CAPTURE(BM_EllipseMask, scalar, &mrt::ellipse_mask_scalar);

}  // namespace

BENCHMARK_MAIN();
