#include "common/image/image_metrics.h"

#include "common/system/error.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace mrt {

namespace {

void check_same_size(const Image& image, const Image& reference) {
    if (image.width() != reference.width() || image.height() != reference.height()) {
        throw Error(fmt::format("image sizes differ: {}×{} vs {}×{}", image.width(), image.height(),
                                reference.width(), reference.height()));
    }
    if (image.empty()) {
        throw Error(
            fmt::format("cannot compare empty images ({}×{})", image.width(), image.height()));
    }
}

std::vector<double> clamped_luminance(const Image& image) {
    const std::vector<float>& px = image.data();
    std::vector<double> y(px.size() / 3);
    for (std::size_t i = 0; i < y.size(); ++i) {
        const double l = 0.2126 * px[3 * i] + 0.7152 * px[3 * i + 1] + 0.0722 * px[3 * i + 2];
        // NaN compares false both ways and would survive std::clamp; count it as black.
        y[i] = std::isnan(l) ? 0.0 : std::clamp(l, 0.0, 1.0);
    }
    return y;
}

constexpr double kC1 = (0.01 * 1.0) * (0.01 * 1.0);
constexpr double kC2 = (0.03 * 1.0) * (0.03 * 1.0);
constexpr int kWindow = 11;
constexpr int kRadius = kWindow / 2;

double ssim_formula(double mx, double my, double vx, double vy, double cxy) {
    return ((2.0 * mx * my + kC1) * (2.0 * cxy + kC2)) /
           ((mx * mx + my * my + kC1) * (vx + vy + kC2));
}

std::array<double, kWindow> gaussian_window() {
    constexpr double sigma = 1.5;
    std::array<double, kWindow> w{};
    double sum = 0.0;
    for (int i = 0; i < kWindow; ++i) {
        const double d = i - kRadius;
        w[static_cast<std::size_t>(i)] = std::exp(-d * d / (2.0 * sigma * sigma));
        sum += w[static_cast<std::size_t>(i)];
    }
    for (double& v : w) {
        v /= sum;
    }
    return w;
}

/// Population statistics over the whole image, for images the window does not fit into.
double global_ssim(const std::vector<double>& x, const std::vector<double>& y) {
    const double n = static_cast<double>(x.size());
    double mx = 0.0;
    double my = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) {
        mx += x[i];
        my += y[i];
    }
    mx /= n;
    my /= n;
    // Centred sums avoid the cancellation of E[x²] − E[x]² on nearly constant images.
    double vx = 0.0;
    double vy = 0.0;
    double cxy = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) {
        const double dx = x[i] - mx;
        const double dy = y[i] - my;
        vx += dx * dx;
        vy += dy * dy;
        cxy += dx * dy;
    }
    return ssim_formula(mx, my, vx / n, vy / n, cxy / n);
}

/// The Gaussian is separable: filter the five moment images along rows over the valid columns,
/// then along columns over the valid rows.
double windowed_ssim(const std::vector<double>& x, const std::vector<double>& y, int width,
                     int height) {
    const std::array<double, kWindow> w = gaussian_window();
    const int out_w = width - kWindow + 1;
    const int out_h = height - kWindow + 1;
    const auto at = [width](int px, int py) {
        return static_cast<std::size_t>(py) * static_cast<std::size_t>(width) +
               static_cast<std::size_t>(px);
    };

    constexpr int kMoments = 5;  // x, y, x², y², xy
    const std::size_t row_size = static_cast<std::size_t>(out_w) * static_cast<std::size_t>(height);
    std::vector<double> rows(row_size * kMoments);
    for (int py = 0; py < height; ++py) {
        for (int ox = 0; ox < out_w; ++ox) {
            std::array<double, kMoments> s{};
            for (int k = 0; k < kWindow; ++k) {
                const std::size_t i = at(ox + k, py);
                const double wk = w[static_cast<std::size_t>(k)];
                s[0] += wk * x[i];
                s[1] += wk * y[i];
                s[2] += wk * x[i] * x[i];
                s[3] += wk * y[i] * y[i];
                s[4] += wk * x[i] * y[i];
            }
            const std::size_t r = static_cast<std::size_t>(py) * static_cast<std::size_t>(out_w) +
                                  static_cast<std::size_t>(ox);
            for (std::size_t m = 0; m < kMoments; ++m) {
                rows[m * row_size + r] = s[m];
            }
        }
    }

    double total = 0.0;
    for (int oy = 0; oy < out_h; ++oy) {
        for (int ox = 0; ox < out_w; ++ox) {
            std::array<double, kMoments> s{};
            for (int k = 0; k < kWindow; ++k) {
                const std::size_t r =
                    static_cast<std::size_t>(oy + k) * static_cast<std::size_t>(out_w) +
                    static_cast<std::size_t>(ox);
                const double wk = w[static_cast<std::size_t>(k)];
                for (std::size_t m = 0; m < kMoments; ++m) {
                    s[m] += wk * rows[m * row_size + r];
                }
            }
            const double mx = s[0];
            const double my = s[1];
            total += ssim_formula(mx, my, s[2] - mx * mx, s[3] - my * my, s[4] - mx * my);
        }
    }
    return total / (static_cast<double>(out_w) * static_cast<double>(out_h));
}

/// RMSE over all pixels and channels of `value` of each channel value.
template <class Value>
double rmse_of(const Image& image, const Image& reference, Value value) {
    check_same_size(image, reference);
    const std::vector<float>& a = image.data();
    const std::vector<float>& b = reference.data();
    double sum = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        const double d = value(static_cast<double>(a[i])) - value(static_cast<double>(b[i]));
        sum += d * d;
    }
    return std::sqrt(sum / static_cast<double>(a.size()));
}

}  // namespace

double rmse(const Image& image, const Image& reference) {
    return rmse_of(image, reference, [](double v) { return v; });
}

double display_rmse(const Image& image, const Image& reference) {
    return rmse_of(image, reference, [](double v) { return std::clamp(v, 0.0, 1.0); });
}

double psnr(const Image& image, const Image& reference, double peak) {
    const double e = rmse(image, reference);
    if (e == 0.0) {
        return std::numeric_limits<double>::infinity();
    }
    return 20.0 * std::log10(peak / e);
}

double ssim(const Image& image, const Image& reference) {
    check_same_size(image, reference);
    const std::vector<double> x = clamped_luminance(image);
    const std::vector<double> y = clamped_luminance(reference);
    if (image.width() < kWindow || image.height() < kWindow) {
        return global_ssim(x, y);
    }
    return windowed_ssim(x, y, image.width(), image.height());
}

Image error_image(const Image& image, const Image& reference, float max_error) {
    check_same_size(image, reference);
    if (!(max_error > 0.0f) || !std::isfinite(max_error)) {
        throw Error(
            fmt::format("error image: max_error must be positive and finite, got {}", max_error));
    }
    // Equally spaced stops of the documented ramp; brightness grows with the error.
    static constexpr std::array<std::array<float, 3>, 6> kStops = {{
        {0.0f, 0.0f, 0.0f},
        {0.0f, 0.0f, 1.0f},
        {0.0f, 1.0f, 0.0f},
        {1.0f, 1.0f, 0.0f},
        {1.0f, 0.0f, 0.0f},
        {1.0f, 1.0f, 1.0f},
    }};
    constexpr int kSegments = static_cast<int>(kStops.size()) - 1;

    Image out(image.width(), image.height());
    for (int py = 0; py < image.height(); ++py) {
        for (int px = 0; px < image.width(); ++px) {
            const Rgb diff = (image.at(px, py) - reference.at(px, py)).abs();
            const float e = diff.sum() / 3.0f;
            // A NaN difference is as wrong as it gets: show it at the top of the scale.
            const float t = std::isnan(e) ? 1.0f : std::clamp(e / max_error, 0.0f, 1.0f);
            const float pos = t * static_cast<float>(kSegments);
            const int seg = std::min(static_cast<int>(pos), kSegments - 1);
            const float f = pos - static_cast<float>(seg);
            const auto& lo = kStops[static_cast<std::size_t>(seg)];
            const auto& hi = kStops[static_cast<std::size_t>(seg + 1)];
            out.set(px, py,
                    Rgb(lo[0] + f * (hi[0] - lo[0]), lo[1] + f * (hi[1] - lo[1]),
                        lo[2] + f * (hi[2] - lo[2])));
        }
    }
    return out;
}

}  // namespace mrt
