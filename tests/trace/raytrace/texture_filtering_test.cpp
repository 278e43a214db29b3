// Texture filtering from ray differentials, end to end (Igehy §4, Figs. 3–5): a checker texture
// on a plane receding to the horizon, rendered by whitted at 1 sample per pixel with each
// filter, against a 256-spp unfiltered (`none`) render as ground truth. Filtering must remove
// the moiré near the horizon, and the better the footprint the lower the error.

#include "common/image/image.h"
#include "common/image/image_metrics.h"
#include "common/scene_io/scene_loader.h"
#include "tests/support/test_support.h"
#include "trace/bvh/scene_bvh.h"
#include "trace/raytrace/distributed.h"
#include "trace/raytrace/whitted.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

namespace mrt {
namespace {

namespace fs = std::filesystem;

/// Writes into `dir` a 64×64 checker of 8×8-texel black/white tiles, tiled 40 times over a
/// floor seen at a low angle (the horizon in the upper part of the image), and its scene:
/// 96×64 square pixels, or `columns` columns of pixels 96/columns times as wide as tall over
/// the same view.
fs::path checker_scene(const fs::path& dir, int columns = 96) {
    Image checker(64, 64);
    for (int y = 0; y < 64; ++y) {
        for (int x = 0; x < 64; ++x) {
            checker.set(x, y, ((x / 8 + y / 8) % 2 == 0) ? Rgb(1, 1, 1) : Rgb(0, 0, 0));
        }
    }
    write_image(dir / "checker.exr", checker);
    std::ofstream(dir / "floor.json") << R"({
      "camera": {"eye": [0, 1.2, 10], "look_at": [0, 0.6, 0], "fov": 40,
                 "resolution": [)" << columns
                                      << R"(, 64], "pixel_aspect": )" << 96.0 / columns << R"(},
      "background": [0.5, 0.5, 0.5],
      "ambient": [1, 1, 1],
      "materials": {"floor": {"diffuse": 1,
                              "texture": {"file": "checker.exr", "srgb": false,
                                          "uv_scale": 40}}},
      "objects": [{"shape": "quad", "size": [40, 200], "material": "floor",
                   "transform": {"translate": [0, 0, -90]}}]
    })";
    return dir / "floor.json";
}

Image render(const Scene& scene, const SceneBvh& bvh, TextureFilter filter, int spp) {
    RenderOptions o = testing::camera_options(scene);
    o.texture_filter = filter;
    return render_whitted(scene, bvh, o, {.spp = spp}).image;
}

TEST(TracedTextureFiltering, FootprintFiltersBeatPointSamplingAgainstASupersampledReference) {
    const testing::ScratchDirectory scratch("mrt_texture_filtering_test");
    const Scene scene = load_scene(checker_scene(scratch.path()));
    const SceneBvh bvh(scene);
    const Image reference = render(scene, bvh, TextureFilter::None, 256);
    std::map<TextureFilter, double> error;
    for (const TextureFilter f : {TextureFilter::None, TextureFilter::Distance,
                                  TextureFilter::Trilinear, TextureFilter::Anisotropic}) {
        error[f] = rmse(render(scene, bvh, f, 1), reference);
    }
    // Igehy's ordering: anisotropic < trilinear < none; distance is no better than trilinear
    // would need (it ignores the surface orientation's anisotropy) but beats no filtering.
    EXPECT_LT(error[TextureFilter::Anisotropic], error[TextureFilter::Trilinear]);
    EXPECT_LT(error[TextureFilter::Trilinear], error[TextureFilter::None]);
    EXPECT_LT(error[TextureFilter::Distance], error[TextureFilter::None]);
    EXPECT_LT(error[TextureFilter::Anisotropic], 0.6 * error[TextureFilter::None]);
}

TEST(TracedTextureFiltering, AnisotropicFollowsTheReferenceNearTheHorizon) {
    // Near the horizon a pixel covers many tiles along the view and few across it: the
    // supersampled reference is grey along z but keeps the stripes across. Anisotropic
    // filtering must reproduce that (no moiré, no over-blur), point sampling cannot.
    const testing::ScratchDirectory scratch("mrt_texture_filtering_test");
    const Scene scene = load_scene(checker_scene(scratch.path()));
    const SceneBvh bvh(scene);
    const Image reference = render(scene, bvh, TextureFilter::None, 256);
    const Image anisotropic = render(scene, bvh, TextureFilter::Anisotropic, 1);
    const Image none = render(scene, bvh, TextureFilter::None, 1);
    int horizon = -1;
    for (int y = 0; y < reference.height(); ++y) {
        if (std::abs(reference.at(48, y)[0] - 0.5f) > 1e-3f) {  // first floor row (sky is 0.5)
            horizon = y;
            break;
        }
    }
    ASSERT_GE(horizon, 0);
    const auto row_error = [&](const Image& image, int y) {
        double sum = 0.0;
        for (int x = 0; x < image.width(); ++x) {
            const double e = image.at(x, y)[0] - reference.at(x, y)[0];
            sum += e * e;
        }
        return std::sqrt(sum / image.width());
    };
    for (int y = horizon + 1; y < horizon + 6; ++y) {
        EXPECT_LT(row_error(anisotropic, y), 0.5 * row_error(none, y)) << "row " << y;
        EXPECT_LT(row_error(anisotropic, y), 0.15) << "row " << y;
    }
}

TEST(TracedTextureFiltering, NonSquarePixelsFilterOverTheirOwnFootprint) {
    // Pixels three times as wide as tall see the same view as three square pixels side by
    // side: the references agree once the square one is averaged over each three columns, and
    // the filters keep their order, since the differentials carry the unequal pixel steps.
    const testing::ScratchDirectory scratch("mrt_texture_filtering_test");
    const Scene square_scene = load_scene(checker_scene(scratch.path()));
    const Scene wide_scene = load_scene(checker_scene(scratch.path(), 32));
    ASSERT_FLOAT_EQ(wide_scene.camera.pixel_aspect, 3.0f);
    const SceneBvh square_bvh(square_scene);
    const SceneBvh wide_bvh(wide_scene);
    const Image square_reference = render(square_scene, square_bvh, TextureFilter::None, 256);
    const Image reference = render(wide_scene, wide_bvh, TextureFilter::None, 256);
    ASSERT_EQ(reference.width(), 32);
    Image averaged(32, 64);
    for (int y = 0; y < 64; ++y) {
        for (int x = 0; x < 32; ++x) {
            averaged.set(x, y,
                         (square_reference.at(3 * x, y) + square_reference.at(3 * x + 1, y) +
                          square_reference.at(3 * x + 2, y)) /
                             3.0f);
        }
    }
    EXPECT_LT(rmse(reference, averaged), 0.01);
    std::map<TextureFilter, double> error;
    for (const TextureFilter f :
         {TextureFilter::None, TextureFilter::Trilinear, TextureFilter::Anisotropic}) {
        error[f] = rmse(render(wide_scene, wide_bvh, f, 1), reference);
    }
    EXPECT_LT(error[TextureFilter::Anisotropic], error[TextureFilter::Trilinear]);
    EXPECT_LT(error[TextureFilter::Trilinear], error[TextureFilter::None]);
    EXPECT_LT(error[TextureFilter::Anisotropic], 0.6 * error[TextureFilter::None]);
}

TEST(TracedTextureFiltering, CarryingDifferentialsUnreadChangesNoPixel) {
    // `always` prices the differentials by computing them where nothing reads them: with the
    // `none` filter the image must be bit-identical, in both tracers.
    const testing::ScratchDirectory scratch("mrt_texture_filtering_test");
    const Scene scene = load_scene(checker_scene(scratch.path()));
    const SceneBvh bvh(scene);
    RenderOptions o = testing::camera_options(scene);
    o.texture_filter = TextureFilter::None;
    const WhittedOptions two_rays{.spp = 2};
    const DistributedOptions two_samples{.sampling = DistributedSampling::Fixed, .spp = 2};
    const Image whitted = render_whitted(scene, bvh, o, two_rays).image;
    const Image distributed = render_distributed(scene, bvh, o, two_samples).image;
    o.differentials = Differentials::Always;
    EXPECT_EQ(render_distributed(scene, bvh, o, two_samples).image.data(), distributed.data());
    EXPECT_EQ(render_whitted(scene, bvh, o, two_rays).image.data(), whitted.data());
    EXPECT_EQ(parse_differentials(to_string(Differentials::Always)), Differentials::Always);
    EXPECT_EQ(parse_differentials("when-read"), Differentials::WhenRead);
    EXPECT_THROW(parse_differentials("sometimes"), Error);
}

TEST(TracedTextureFiltering, DistributedCarriesTheSameFootprints) {
    const testing::ScratchDirectory scratch("mrt_texture_filtering_test");
    const Scene scene = load_scene(checker_scene(scratch.path()));
    const SceneBvh bvh(scene);
    RenderOptions o = testing::camera_options(scene);
    const DistributedOptions one_sample{.sampling = DistributedSampling::Fixed, .spp = 1};
    o.texture_filter = TextureFilter::Anisotropic;
    const Image filtered = render_distributed(scene, bvh, o, one_sample).image;
    o.texture_filter = TextureFilter::None;
    const Image unfiltered = render_distributed(scene, bvh, o, one_sample).image;
    const Image reference = render(scene, bvh, TextureFilter::None, 256);
    EXPECT_LT(rmse(filtered, reference), rmse(unfiltered, reference));
    for (const float v : filtered.data()) {
        ASSERT_TRUE(std::isfinite(v));
    }
}

}  // namespace
}  // namespace mrt
