#include "common/image/image_metrics.h"

#include "common/system/error.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>

namespace {

using mrt::Image;
using mrt::Rgb;

// Deterministic test images: a smooth colour pattern plus integer-hash noise. The reference SSIM
// values below were computed from exactly these images (see SsimMatchesScikitImage).

std::uint32_t mix_bits(std::uint32_t v) {
    v ^= v >> 16;
    v *= 0x7feb352dU;
    v ^= v >> 15;
    v *= 0x846ca68bU;
    v ^= v >> 16;
    return v;
}

/// Uniform in [0, 1) with 24 bits, exact in float and double.
float hash_noise(std::uint32_t seed, int x, int y, int c) {
    const std::uint32_t h = mix_bits(
        mix_bits(mix_bits(seed + static_cast<std::uint32_t>(c)) + static_cast<std::uint32_t>(y)) +
        static_cast<std::uint32_t>(x));
    return static_cast<float>(h >> 8) * (1.0f / 16777216.0f);
}

Image sine_pattern(int width, int height) {
    Image image(width, height);
    for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) {
            Rgb c;
            for (int k = 0; k < 3; ++k) {
                c[k] = static_cast<float>(0.5 + 0.4 * std::sin(0.45 * x + 0.3 * y + 1.7 * k) *
                                                    std::cos(0.2 * x - 0.35 * y));
            }
            image.set(x, y, c);
        }
    }
    return image;
}

Image with_noise(const Image& image, std::uint32_t seed, float amplitude) {
    Image out = image;
    for (int y = 0; y < image.height(); ++y) {
        for (int x = 0; x < image.width(); ++x) {
            Rgb c = image.at(x, y);
            for (int k = 0; k < 3; ++k) {
                c[k] = c[k] + amplitude * (hash_noise(seed, x, y, k) - 0.5f);
            }
            out.set(x, y, c);
        }
    }
    return out;
}

Image with_gain(const Image& image, float gain, float offset) {
    Image out = image;
    for (float& v : out.data()) {
        v = v * gain + offset;
    }
    return out;
}

Image shifted_left(const Image& image) {
    Image out = image;
    for (int y = 0; y < image.height(); ++y) {
        for (int x = 0; x < image.width(); ++x) {
            out.set(x, y, image.at((x + 1) % image.width(), y));
        }
    }
    return out;
}

using mrt::testing::error_message;

/// SSIM of two constant images: the structure term is C2/C2 and only luminance remains.
double constant_ssim(double a, double b) {
    const double c1 = 0.01 * 0.01;
    return (2.0 * a * b + c1) / (a * a + b * b + c1);
}

TEST(Rmse, ConstantOffsetGivesTheOffset) {
    // Dyadic values: the differences are exact in float.
    const Image a(20, 10, Rgb(0.25f, 0.5f, 0.75f));
    const Image b(20, 10, Rgb(0.375f, 0.625f, 0.875f));
    EXPECT_DOUBLE_EQ(mrt::rmse(a, b), 0.125);
    EXPECT_DOUBLE_EQ(mrt::rmse(b, a), 0.125);
}

TEST(Rmse, OffsetOnAPatternGivesTheOffset) {
    const Image ref = sine_pattern(33, 17);
    const Image img = with_gain(ref, 1.0f, 0.01f);
    EXPECT_NEAR(mrt::rmse(img, ref), 0.01, 1e-7);
}

TEST(Rmse, AveragesOverAllChannels) {
    // Only red differs, by d: mean square over three channels is d²/3.
    const Image a(8, 8, Rgb(0.5f, 0.5f, 0.5f));
    const Image b(8, 8, Rgb(0.75f, 0.5f, 0.5f));
    EXPECT_NEAR(mrt::rmse(a, b), 0.25 / std::sqrt(3.0), 1e-15);
}

TEST(Rmse, SinglePixelErrorIsDilutedByPixelCount) {
    const Image a(10, 10, Rgb(0.5f, 0.5f, 0.5f));
    Image b = a;
    b.set(3, 7, Rgb(1.5f, 1.5f, 1.5f));
    EXPECT_NEAR(mrt::rmse(a, b), std::sqrt(3.0 / 300.0), 1e-15);
}

TEST(DisplayRmse, ClampsBothImagesToTheDisplayRangeFirst) {
    // Within [0, 1] it is the RMSE.
    const Image ref = sine_pattern(33, 17);
    const Image img = with_gain(ref, 0.9f, 0.02f);
    EXPECT_DOUBLE_EQ(mrt::display_rmse(img, ref), mrt::rmse(img, ref));
    // A highlight of 40 against 10 is white against white on a screen: no error at all; a value
    // of 3 against 0.5 differs by 0.5, and a negative one by its distance from 0.
    const Image a(10, 10, Rgb(0.5f, 0.5f, 0.5f));
    Image b = a;
    Image c = a;
    c.set(3, 7, Rgb(40.0f, 40.0f, 40.0f));
    b.set(3, 7, Rgb(10.0f, 10.0f, 10.0f));
    EXPECT_EQ(mrt::display_rmse(b, c), 0.0);
    EXPECT_NEAR(mrt::rmse(b, c), std::sqrt(3.0 * 900.0 / 300.0), 1e-12);
    b.set(3, 7, Rgb(3.0f, 0.5f, -0.25f));
    EXPECT_NEAR(mrt::display_rmse(b, a), std::sqrt((0.25 + 0.25) / 300.0), 1e-15);
}

TEST(Psnr, ConstantOffsetGivesMinusTwentyLogOffset) {
    const Image a(16, 16, Rgb(0.25f, 0.25f, 0.25f));
    const Image b(16, 16, Rgb(0.375f, 0.375f, 0.375f));
    EXPECT_NEAR(mrt::psnr(a, b), -20.0 * std::log10(0.125), 1e-12);
    EXPECT_NEAR(mrt::psnr(a, b, 4.0), 20.0 * std::log10(4.0 / 0.125), 1e-12);
}

TEST(Psnr, IdenticalImagesAreInfinitelyGood) {
    const Image a = sine_pattern(12, 9);
    EXPECT_EQ(mrt::psnr(a, a), std::numeric_limits<double>::infinity());
    EXPECT_EQ(mrt::rmse(a, a), 0.0);
}

TEST(Metrics, SizeMismatchIsAnErrorNamingBothSizes) {
    const Image a(64, 64);
    const Image b(32, 32);
    const std::string expected = "image sizes differ: 64×64 vs 32×32";
    EXPECT_EQ(error_message([&] { mrt::rmse(a, b); }), expected);
    EXPECT_EQ(error_message([&] { mrt::psnr(a, b); }), expected);
    EXPECT_EQ(error_message([&] { mrt::ssim(a, b); }), expected);
    EXPECT_EQ(error_message([&] { mrt::error_image(a, b, 1.0f); }), expected);
    EXPECT_EQ(error_message([&] { mrt::rmse(Image(64, 32), Image(32, 64)); }),
              "image sizes differ: 64×32 vs 32×64");
}

TEST(Metrics, EmptyImagesAreAnError) {
    EXPECT_THROW(mrt::rmse(Image(), Image()), mrt::Error);
    EXPECT_THROW(mrt::ssim(Image(0, 5), Image(0, 5)), mrt::Error);
}

TEST(Ssim, IdenticalImagesGiveOne) {
    const Image large = with_noise(sine_pattern(40, 30), 11u, 0.3f);
    EXPECT_NEAR(mrt::ssim(large, large), 1.0, 1e-12);
    const Image small = with_noise(sine_pattern(6, 5), 11u, 0.3f);
    EXPECT_NEAR(mrt::ssim(small, small), 1.0, 1e-12);
}

TEST(Ssim, ConstantImagesMatchClosedForm) {
    for (const auto& [a, b] :
         {std::pair{0.2f, 0.6f}, std::pair{0.05f, 0.9f}, std::pair{0.5f, 0.5f}}) {
        // Grey pixels: the luminance weights sum to one, so Y equals the grey value.
        const double expected = constant_ssim(a, b);
        EXPECT_NEAR(mrt::ssim(Image(32, 24, Rgb(a, a, a)), Image(32, 24, Rgb(b, b, b))), expected,
                    1e-9)
            << a << " vs " << b;
        EXPECT_NEAR(mrt::ssim(Image(7, 4, Rgb(a, a, a)), Image(7, 4, Rgb(b, b, b))), expected, 1e-9)
            << a << " vs " << b << " (smaller than the window)";
    }
}

TEST(Ssim, LuminanceIsClampedToUnitRange) {
    // Both sides clamp to 1 (and to 0): no difference remains.
    EXPECT_NEAR(
        mrt::ssim(Image(16, 16, Rgb(2.0f, 2.0f, 2.0f)), Image(16, 16, Rgb(1.0f, 1.0f, 1.0f))), 1.0,
        1e-12);
    EXPECT_NEAR(mrt::ssim(Image(16, 16, Rgb(-1.0f, -3.0f, -1.0f)), Image(16, 16)), 1.0, 1e-12);
    EXPECT_NEAR(
        mrt::ssim(Image(16, 16, Rgb(5.0f, 5.0f, 5.0f)), Image(16, 16, Rgb(0.375f, 0.375f, 0.375f))),
        constant_ssim(1.0, 0.375), 1e-9);
}

TEST(Ssim, IsSymmetric) {
    const Image ref = sine_pattern(30, 20);
    const Image img = with_noise(ref, 2u, 0.4f);
    EXPECT_NEAR(mrt::ssim(img, ref), mrt::ssim(ref, img), 1e-12);
}

// Reference values from scikit-image 0.19.3 (numpy 1.24.2, scipy 1.10.1; Debian 12
// python3-skimage), on the luminance of the images built above:
//   Y = clip(0.2126 R + 0.7152 G + 0.0722 B, 0, 1) in float64 from the float32 pixels;
//   skimage.metrics.structural_similarity(Y_img, Y_ref, gaussian_weights=True, sigma=1.5,
//                                         use_sample_covariance=False, data_range=1.0)
// The images were regenerated in numpy with the same formulas (float32 arithmetic, the hash in
// uint32) and checked bit-identical against a dump of the C++ images. For images smaller than the
// window, which scikit-image rejects, the same script evaluated the SSIM formula once with
// population means, variances and covariance over the whole image.
TEST(Ssim, MatchesScikitImage) {
    const Image ref = sine_pattern(48, 40);
    EXPECT_NEAR(mrt::ssim(with_noise(ref, 7u, 0.2f), ref), 0.930790519366, 1e-9);
    EXPECT_NEAR(mrt::ssim(ref, with_noise(ref, 7u, 0.2f)), 0.930790519366, 1e-9);
    // Luminance leaves [0, 1] on about 28 % of the pixels: the clamp matters here.
    EXPECT_NEAR(mrt::ssim(with_gain(ref, 3.0f, -1.0f), ref), 0.645584867904, 1e-9);
    EXPECT_NEAR(mrt::ssim(shifted_left(ref), ref), 0.879194182110, 1e-9);

    // Exactly one window position.
    const Image ref11 = sine_pattern(11, 11);
    EXPECT_NEAR(mrt::ssim(with_noise(ref11, 3u, 0.3f), ref11), 0.835650797852, 1e-9);
}

TEST(Ssim, SmallerThanWindowUsesGlobalStatistics) {
    const Image ref97 = sine_pattern(9, 7);
    EXPECT_NEAR(mrt::ssim(with_noise(ref97, 5u, 0.3f), ref97), 0.877226264352, 1e-9);
    // Only the height is below the window.
    const Image ref248 = sine_pattern(24, 8);
    EXPECT_NEAR(mrt::ssim(with_noise(ref248, 9u, 0.25f), ref248), 0.927405739819, 1e-9);
}

TEST(ErrorImage, ZeroErrorIsBlack) {
    const Image ref = sine_pattern(7, 5);
    const Image err = mrt::error_image(ref, ref, 0.1f);
    ASSERT_EQ(err.width(), 7);
    ASSERT_EQ(err.height(), 5);
    for (const float v : err.data()) {
        EXPECT_EQ(v, 0.0f);
    }
}

TEST(ErrorImage, MaxErrorAndAboveIsWhite) {
    const Image ref(4, 3, Rgb(0.5f, 0.5f, 0.5f));
    const Image at_max(4, 3, Rgb(0.75f, 0.25f, 0.75f));  // mean |diff| = 0.25
    const Image above(4, 3, Rgb(3.0f, 3.0f, 3.0f));
    for (const Image* img : {&at_max, &above}) {
        const Image err = mrt::error_image(*img, ref, 0.25f);
        for (const float v : err.data()) {
            EXPECT_FLOAT_EQ(v, 1.0f);
        }
    }
}

TEST(ErrorImage, FollowsTheDocumentedRamp) {
    // Stops at equal spacing: black, blue, green, yellow, red, white.
    const Image ref(1, 1);
    const auto colour_for = [&](float error) {
        return mrt::error_image(Image(1, 1, Rgb(error, error, error)), ref, 1.0f).at(0, 0);
    };
    EXPECT_TRUE(colour_for(0.2f).isApprox(Rgb(0.0f, 0.0f, 1.0f), 1e-5f));
    EXPECT_TRUE(colour_for(0.4f).isApprox(Rgb(0.0f, 1.0f, 0.0f), 1e-5f));
    EXPECT_TRUE(colour_for(0.6f).isApprox(Rgb(1.0f, 1.0f, 0.0f), 1e-5f));
    EXPECT_TRUE(colour_for(0.8f).isApprox(Rgb(1.0f, 0.0f, 0.0f), 1e-5f));
    EXPECT_TRUE(colour_for(0.1f).isApprox(Rgb(0.0f, 0.0f, 0.5f), 1e-5f));
    EXPECT_TRUE(colour_for(0.9f).isApprox(Rgb(1.0f, 0.5f, 0.5f), 1e-5f));
}

TEST(ErrorImage, UsesTheChannelMeanOfTheAbsoluteDifference) {
    // Signed differences +0.3, −0.3, 0 would cancel in a plain mean; absolute ones give 0.2.
    const Image img(1, 1, Rgb(0.8f, 0.2f, 0.5f));
    const Image ref(1, 1, Rgb(0.5f, 0.5f, 0.5f));
    EXPECT_TRUE(mrt::error_image(img, ref, 1.0f).at(0, 0).isApprox(Rgb(0.0f, 0.0f, 1.0f), 1e-5f));
}

TEST(ErrorImage, NanErrorIsShownAsMaximum) {
    const Image img(1, 1, Rgb(std::nanf(""), 0.0f, 0.0f));
    EXPECT_TRUE(mrt::error_image(img, Image(1, 1), 1.0f).at(0, 0).isApprox(Rgb(1.0f, 1.0f, 1.0f)));
}

TEST(ErrorImage, NonPositiveScaleIsAnError) {
    EXPECT_THROW(mrt::error_image(Image(2, 2), Image(2, 2), 0.0f), mrt::Error);
    EXPECT_THROW(mrt::error_image(Image(2, 2), Image(2, 2), -1.0f), mrt::Error);
}

}  // namespace
