// The film: reconstruction filters applied by splatting, across tile borders, independent of
// the thread count, and never poisoned by a non-finite sample.

#include "trace/render/film.h"

#include "common/math/random.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace mrt {
namespace {

TEST(Film, BoxFilterWithOneSamplePerPixelIsThatSample) {
    Film film(37, 21, PixelFilter::box());
    film.add_pass(2, "test", true, [](int x, int y, FilmTile& tile, RayCounters&) {
        tile.add_sample(static_cast<float>(x) + 0.99f, static_cast<float>(y),
                        Rgb(static_cast<float>(x), static_cast<float>(y), 1.0f));
    });
    const Image image = film.image();
    for (int y = 0; y < 21; ++y) {
        for (int x = 0; x < 37; ++x) {
            EXPECT_EQ(image.at(x, y)[0], static_cast<float>(x));
            EXPECT_EQ(image.at(x, y)[1], static_cast<float>(y));
        }
    }
}

TEST(Film, GaussianOfConstantRadianceIsConstantUpToTheBorder) {
    Film film(40, 33, PixelFilter::gaussian(0.8f));
    film.add_pass(3, "test", true, [](int x, int y, FilmTile& tile, RayCounters&) {
        for (int s = 0; s < 3; ++s) {
            SampleRng rng(7, static_cast<std::uint32_t>(x), static_cast<std::uint32_t>(y),
                          static_cast<std::uint32_t>(s));
            tile.add_sample(static_cast<float>(x) + rng.uniform(),
                            static_cast<float>(y) + rng.uniform(), Rgb(0.25f, 0.5f, 2.0f));
        }
    });
    const Image image = film.image();
    for (int y = 0; y < 33; ++y) {
        for (int x = 0; x < 40; ++x) {
            EXPECT_NEAR(image.at(x, y)[0], 0.25f, 1e-6f);
            EXPECT_NEAR(image.at(x, y)[2], 2.0f, 1e-5f);
        }
    }
}

TEST(Film, GaussianSplatReachesAcrossATileBorderAndNoFurther) {
    // σ = 0.5 → support radius 1.5 px: a sample at x = 15.9 (last column of the first tile)
    // reaches the centres 14.5 … 16.5 but not 17.5.
    Film film(48, 16, PixelFilter::gaussian(0.5f));
    film.add_pass(2, "test", true, [](int x, int y, FilmTile& tile, RayCounters&) {
        if (x == 15 && y == 5) {
            tile.add_sample(15.9f, 5.5f, Rgb(1.0f, 2.0f, 3.0f));
        }
    });
    const Image image = film.image();
    EXPECT_EQ(image.at(16, 5)[1], 2.0f);  // only sample there: the weighted mean is the sample
    EXPECT_EQ(image.at(14, 5)[1], 2.0f);
    EXPECT_EQ(image.at(16, 6)[1], 2.0f);
    EXPECT_EQ(image.at(17, 5)[1], 0.0f);
    EXPECT_EQ(image.at(13, 5)[1], 0.0f);
    EXPECT_EQ(image.at(15, 7)[1], 0.0f);
}

TEST(Film, ImageIsBitIdenticalForAnyThreadCount) {
    const auto render = [](int threads) {
        Film film(70, 45, PixelFilter::gaussian(1.0f));
        film.add_pass(threads, "test", true, [](int x, int y, FilmTile& tile, RayCounters& c) {
            for (int s = 0; s < 4; ++s) {
                SampleRng rng(3, static_cast<std::uint32_t>(x), static_cast<std::uint32_t>(y),
                              static_cast<std::uint32_t>(s));
                const float v = rng.uniform();
                tile.add_sample(static_cast<float>(x) + rng.uniform(),
                                static_cast<float>(y) + rng.uniform(), Rgb(v, v * v, 1.0f - v));
                ++c.primary;
            }
        });
        return film.image();
    };
    const Image one = render(1);
    const Image four = render(4);
    ASSERT_EQ(one.data().size(), four.data().size());
    for (std::size_t i = 0; i < one.data().size(); ++i) {
        ASSERT_EQ(one.data()[i], four.data()[i]) << "value " << i;
    }
}

TEST(Film, NonFiniteSamplesCountAsBlackAndNeverReachAPixel) {
    Film film(20, 20, PixelFilter::gaussian(0.5f));
    film.add_pass(2, "test", true, [](int x, int y, FilmTile& tile, RayCounters&) {
        const float bad = (x + y) % 2 == 0 ? std::numeric_limits<float>::quiet_NaN()
                                           : std::numeric_limits<float>::infinity();
        tile.add_sample(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f,
                        Rgb(bad, 1.0f, 1.0f));
    });
    const Image image = film.image();
    for (const float v : image.data()) {
        ASSERT_TRUE(std::isfinite(v));
    }
    EXPECT_EQ(image.at(10, 10)[0], 0.0f);
}

TEST(Film, CountsRaysOverAllThreads) {
    Film film(33, 17, PixelFilter::box());
    const RayCounters rays =
        film.add_pass(3, "test", true, [](int, int, FilmTile&, RayCounters& c) { c.primary += 2; });
    EXPECT_EQ(rays.primary, 2u * 33u * 17u);
}

}  // namespace
}  // namespace mrt
