// Pixel filters: support, continuity, separability, and the command-line spelling.

#include "trace/render/pixel_filter.h"
#include "common/system/error.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>

namespace mrt {
namespace {

TEST(PixelFilter, BoxCoversExactlyThePixel) {
    const PixelFilter f = PixelFilter::box();
    EXPECT_EQ(f.weight(0.0f, 0.0f), 1.0f);
    EXPECT_EQ(f.weight(0.49f, -0.49f), 1.0f);
    EXPECT_EQ(f.weight(0.51f, 0.0f), 0.0f);
    EXPECT_EQ(f.weight(0.0f, -0.51f), 0.0f);
}

TEST(PixelFilter, GaussianIsSeparableAndFallsContinuouslyToZero) {
    const PixelFilter f = PixelFilter::gaussian(0.5f);
    EXPECT_FLOAT_EQ(f.radius, 1.5f);
    // Separable: w(x, y)·w(0, 0) = w(x, 0)·w(0, y).
    EXPECT_NEAR(f.weight(0.3f, 0.7f) * f.weight(0.0f, 0.0f),
                f.weight(0.3f, 0.0f) * f.weight(0.0f, 0.7f), 1e-7f);
    // Shape: ratio of weights is the Gaussian's, less the edge offset.
    const float edge = std::exp(-1.5f * 1.5f / 0.5f);
    EXPECT_NEAR(f.weight(0.5f, 0.0f) / f.weight(0.0f, 0.0f),
                (std::exp(-0.5f * 0.5f / 0.5f) - edge) / (1.0f - edge), 1e-6f);
    EXPECT_NEAR(f.weight(1.4999f, 0.0f), 0.0f, 1e-4f);
    EXPECT_EQ(f.weight(1.6f, 0.0f), 0.0f);
    EXPECT_GT(f.weight(1.4f, 1.4f), 0.0f);
    // A narrow Gaussian still covers its own pixel.
    EXPECT_FLOAT_EQ(PixelFilter::gaussian(0.05f).radius, 0.5f);
}

TEST(PixelFilter, ParsesItsSpellingsAndRefusesOthers) {
    EXPECT_EQ(parse_pixel_filter("box").kind, PixelFilter::Kind::Box);
    EXPECT_EQ(parse_pixel_filter("gaussian").kind, PixelFilter::Kind::Gaussian);
    EXPECT_FLOAT_EQ(parse_pixel_filter("gaussian").sigma, 0.5f);
    EXPECT_FLOAT_EQ(parse_pixel_filter("gaussian:1.25").sigma, 1.25f);
    for (const char* bad : {"", "tent", "gaussian:", "gaussian:0", "gaussian:-1", "gaussian:x",
                            "gaussian:1.5x", "gaussian:100", "gaussian:nan", "gaussian1"}) {
        EXPECT_THROW(parse_pixel_filter(bad), Error) << bad;
    }
    EXPECT_EQ(testing::error_message([] { parse_pixel_filter("tent"); }),
              "pixel filter: found \"tent\", expected box, gaussian or gaussian:SIGMA with "
              "SIGMA in (0, 16] pixels");
}

}  // namespace
}  // namespace mrt
