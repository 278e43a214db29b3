#include "trace/raytrace/distributed.h"

#include "common/math/random.h"
#include "common/math/sampling.h"
#include "common/system/stopwatch.h"
#include "common/texture/texture.h"
#include "trace/raytrace/ray_tree.h"
#include "trace/render/camera_rays.h"
#include "trace/render/film.h"
#include "trace/render/method.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

namespace mrt {

namespace {

/// Side of the square neighbourhood whose pooled samples estimate a pixel's variance.
constexpr int kNeighbourhood = 5;

/// Batches of a reference: enough for a stable spread, few enough that each stays stratified.
constexpr int kReferenceBatches = 8;

/// Luminance moments of the samples taken in one pixel.
struct PixelMoments {
    int count = 0;
    double sum = 0.0;
    double sum_squares = 0.0;

    PixelMoments& operator+=(const PixelMoments& o) {
        count += o.count;
        sum += o.sum;
        sum_squares += o.sum_squares;
        return *this;
    }
};

class DistributedRenderer {
  public:
    DistributedRenderer(const Scene& scene, const SceneBvh& bvh, const TextureSampler& textures,
                        const RenderOptions& options)
        : m_options(options),
          m_camera(scene.camera, options.width, options.height),
          m_tree(scene, bvh, textures, options.max_depth >= 0 ? options.max_depth : scene.max_depth,
                 options.differentials),
          m_film(options.width, options.height, options.filter, options.crop),
          m_moments(pixel_count()) {}

    std::size_t pixel_count() const {
        return static_cast<std::size_t>(m_options.width) *
               static_cast<std::size_t>(m_options.height);
    }
    Film& film() { return m_film; }
    /// Pixels of the window the image is rendered for.
    std::size_t window_pixel_count() const { return m_film.window().area(); }
    const std::vector<PixelMoments>& moments() const { return m_moments; }

    /// One pass in which pixel i receives a new stratified batch of counts[i] samples (or
    /// `uniform` samples everywhere when counts is empty), over the window and `margin` pixels
    /// around it beyond the filter's reach. Returns the samples taken.
    std::uint64_t pass(const std::vector<int>& counts, int uniform, const std::string& label,
                       RayCounters& rays, int margin) {
        const std::uint64_t seed = mix64(m_options.seed ^ mix64(0xd157'0000ULL + m_passes));
        ++m_passes;
        std::atomic<std::uint64_t> samples{0};
        rays += m_film.add_pass(
            m_options.threads, label, m_options.quiet,
            [&](int x, int y, FilmTile& tile, RayCounters& counters) {
                const std::size_t i =
                    static_cast<std::size_t>(y) * static_cast<std::size_t>(m_options.width) +
                    static_cast<std::size_t>(x);
                const int count = counts.empty() ? uniform : counts[i];
                PixelMoments& moments = m_moments[i];
                for (int k = 0; k < count; ++k) {
                    const double l = luminance(sample(x, y, seed, k, count, tile, counters));
                    moments += PixelMoments{1, l, l * l};
                }
                samples.fetch_add(static_cast<std::uint64_t>(std::max(0, count)),
                                  std::memory_order_relaxed);
            },
            margin);
        return samples.load();
    }

    int passes() const { return m_passes; }

    /// Variance of the sample luminances pooled over each pixel's 5×5 neighbourhood (clipped
    /// at the image border); zero where fewer than two samples are pooled.
    std::vector<double> neighbourhood_variance() const {
        const int w = m_options.width;
        const int h = m_options.height;
        const int r = kNeighbourhood / 2;
        // Separable box sums: rows first, then columns.
        std::vector<PixelMoments> rows(pixel_count());
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
                PixelMoments s;
                for (int xx = std::max(0, x - r); xx <= std::min(w - 1, x + r); ++xx) {
                    s += m_moments[index(xx, y)];
                }
                rows[index(x, y)] = s;
            }
        }
        std::vector<double> variance(pixel_count(), 0.0);
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
                PixelMoments s;
                for (int yy = std::max(0, y - r); yy <= std::min(h - 1, y + r); ++yy) {
                    s += rows[index(x, yy)];
                }
                if (s.count > 1) {
                    const double n = s.count;
                    variance[index(x, y)] =
                        std::max(0.0, (s.sum_squares - s.sum * s.sum / n) / (n - 1.0));
                }
            }
        }
        return variance;
    }

  private:
    std::size_t index(int x, int y) const {
        return static_cast<std::size_t>(y) * static_cast<std::size_t>(m_options.width) +
               static_cast<std::size_t>(x);
    }

    /// Sample `index` of a batch of `count` in pixel (x, y): traced, splatted, returned.
    Rgb sample(int x, int y, std::uint64_t seed, int index, int count, FilmTile& tile,
               RayCounters& counters) const {
        StratifiedSampler sampler(seed, x, y, index, count);
        const Vec2f position = sampler.next_2d();
        const Vec2f lens = sampler.next_2d();
        const float rx = static_cast<float>(x) + position.x();
        const float ry = static_cast<float>(y) + position.y();
        ++counters.primary;
        StochasticSampling sampling(sampler);
        Rgb radiance = m_tree.camera_radiance(
            m_camera.lens_ray(rx, ry, lens.x(), lens.y()),
            [&] {
                return m_camera.lens_differential(rx, ry, lens.x(), lens.y(),
                                                  footprint_scale(count));
            },
            counters, sampling);
        if (!radiance.allFinite()) {
            radiance = Rgb::Zero();
        }
        tile.add_sample(rx, ry, radiance);
        return radiance;
    }

    const RenderOptions& m_options;
    CameraRays m_camera;
    RayTree<StochasticSampling> m_tree;
    Film m_film;
    std::vector<PixelMoments> m_moments;
    int m_passes = 0;
};

/// Pass 2 of the paper: each pixel's total rises to what its neighbourhood variance needs for
/// the target standard error, between what it has and spp_max.
std::vector<int> second_pass_counts(const std::vector<double>& variance,
                                    const std::vector<PixelMoments>& moments,
                                    const DistributedOptions& sampling) {
    const double target = static_cast<double>(sampling.target_error);
    std::vector<int> counts(variance.size(), 0);
    for (std::size_t i = 0; i < variance.size(); ++i) {
        const double wanted = std::ceil(variance[i] / (target * target));
        const double total =
            std::clamp(wanted, static_cast<double>(moments[i].count), double(sampling.spp_max));
        counts[i] = std::max(0, static_cast<int>(total) - moments[i].count);
    }
    return counts;
}

/// A time-budget refinement pass of about `budget` samples: each pixel gets samples in
/// proportion to the squared error one more sample removes there (var/n²), at most doubling
/// and at most up to spp_max; fractions are rounded up or down by a hashed coin so the
/// expected total is the budget.
std::vector<int> refinement_counts(const std::vector<double>& variance,
                                   const std::vector<PixelMoments>& moments,
                                   const DistributedOptions& sampling, std::uint64_t seed,
                                   double budget, int pass) {
    std::vector<double> gain(variance.size(), 0.0);
    double total_gain = 0.0;
    for (std::size_t i = 0; i < variance.size(); ++i) {
        const int n = moments[i].count;
        if (n > 0 && n < sampling.spp_max) {
            gain[i] = variance[i] / (static_cast<double>(n) * static_cast<double>(n));
            total_gain += gain[i];
        }
    }
    std::vector<int> counts(variance.size(), 0);
    if (!(total_gain > 0.0)) {
        return counts;
    }
    for (std::size_t i = 0; i < variance.size(); ++i) {
        if (gain[i] <= 0.0) {
            continue;
        }
        const double share = budget * gain[i] / total_gain;
        const double coin =
            static_cast<double>(mix64(seed ^ mix64((static_cast<std::uint64_t>(pass) << 40) ^ i)) >>
                                11) *
            0x1.0p-53;
        const int n = moments[i].count;
        const int wanted = static_cast<int>(std::min(std::floor(share + coin), 1e9));
        counts[i] = std::min({wanted, n, sampling.spp_max - n});
    }
    return counts;
}

/// Number of independent batches a reference of `spp` samples is split into.
int reference_batch_count(int spp) {
    return std::clamp(spp, 1, kReferenceBatches);
}

}  // namespace

RenderOutput render_distributed(const Scene& scene, const SceneBvh& bvh,
                                const RenderOptions& options,
                                const DistributedOptions& distributed) {
    const TextureSampler textures(scene, options.texture_filter);
    return render_distributed(scene, bvh, textures, options, distributed);
}

RenderOutput render_distributed(const Scene& scene, const SceneBvh& bvh,
                                const TextureSampler& textures, const RenderOptions& options,
                                const DistributedOptions& distributed) {
    const auto start = Clock::now();
    DistributedRenderer renderer(scene, bvh, textures, options);
    RenderOutput out;
    const std::vector<int> uniform;
    // A pass that a neighbourhood-variance pass follows covers the neighbourhood's reach
    // beyond the window too, so that a crop's pixels are decided as in the whole frame.
    auto timed_pass = [&](const std::vector<int>& counts, int count, const std::string& label,
                          int margin = 0) {
        const auto pass_start = Clock::now();
        const std::uint64_t samples = renderer.pass(counts, count, label, out.rays, margin);
        out.samples += samples;
        out.last_pass_seconds = seconds_since(pass_start);
        return samples;
    };

    if (distributed.sampling == DistributedSampling::Reference) {
        // Independent stratified batches: their spread measures the reference's own error.
        const int batches = reference_batch_count(distributed.spp);
        const int per_batch = (std::max(1, distributed.spp) + batches - 1) / batches;
        const std::size_t values = renderer.window_pixel_count() * 3;
        std::vector<double> sum(values, 0.0);
        std::vector<double> sum_squares(values, 0.0);
        for (int b = 0; b < batches; ++b) {
            renderer.film().clear();
            timed_pass(uniform, per_batch,
                       "reference " + std::to_string(b + 1) + "/" + std::to_string(batches));
            const Image batch = renderer.film().image();
            for (std::size_t i = 0; i < values; ++i) {
                const double v = batch.data()[i];
                sum[i] += v;
                sum_squares[i] += v * v;
            }
        }
        const PixelWindow window = output_window(options);
        out.image = Image(window.width(), window.height());
        double squared_error = 0.0;
        const double n = batches;
        for (std::size_t i = 0; i < values; ++i) {
            const double mean = sum[i] / n;
            out.image.data()[i] = static_cast<float>(mean);
            if (batches > 1) {
                const double variance = std::max(0.0, (sum_squares[i] - sum[i] * mean) / (n - 1.0));
                squared_error += variance / n;
            }
        }
        if (batches > 1) {
            out.std_error = std::sqrt(squared_error / static_cast<double>(values));
        }
        out.spp = batches * per_batch;
        out.passes = renderer.passes();
        out.render_seconds = seconds_since(start);
        return out;
    }

    const bool fixed = distributed.sampling == DistributedSampling::Fixed;
    out.spp = fixed ? std::max(1, distributed.spp) : distributed.spp_max;
    if (fixed) {
        timed_pass(uniform, std::max(1, distributed.spp),
                   std::string(to_string(Method::Distributed)));
    } else {
        const int initial = std::max(1, distributed.spp_initial);
        const std::uint64_t first =
            timed_pass(uniform, initial, "distributed pass 1", kNeighbourhood / 2);
        if (distributed.time_budget > 0.0) {
            // A time budget is the window's: it is spent where the window's pixels need it.
            const double pass_size = static_cast<double>(renderer.window_pixel_count()) *
                                     static_cast<double>(std::max(2, initial));
            double seconds_per_sample = out.last_pass_seconds / static_cast<double>(first);
            while (true) {
                const double remaining = distributed.time_budget - seconds_since(start);
                // A pass no bigger than what the measured speed says fits in the time left;
                // tiny passes are not worth their per-pass cost (variance, film merge).
                const double budget = std::min(pass_size, 0.9 * remaining / seconds_per_sample);
                if (remaining <= 0.0 ||
                    budget <
                        std::max(1.0, static_cast<double>(renderer.window_pixel_count()) / 32.0)) {
                    break;
                }
                const auto pass_start = Clock::now();
                const std::vector<int> counts =
                    refinement_counts(renderer.neighbourhood_variance(), renderer.moments(),
                                      distributed, options.seed, budget, renderer.passes());
                const std::uint64_t samples = timed_pass(
                    counts, 0, "distributed pass " + std::to_string(renderer.passes() + 1),
                    kNeighbourhood / 2);
                if (samples == 0) {
                    break;
                }
                seconds_per_sample = seconds_since(pass_start) / static_cast<double>(samples);
            }
        } else {
            const std::vector<int> counts = second_pass_counts(renderer.neighbourhood_variance(),
                                                               renderer.moments(), distributed);
            timed_pass(counts, 0, "distributed pass 2");
        }
    }
    out.image = renderer.film().image();
    out.passes = renderer.passes();
    out.render_seconds = seconds_since(start);
    return out;
}

}  // namespace mrt
