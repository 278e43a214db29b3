// Rendering a window of the frame (RenderOptions::crop, mrt-trace --crop): a frame rendered as
// four crops and pasted together is the full render bit for bit, for every method and mode
// whose samples do not depend on the window (whitted, distributed with fixed or adaptive
// counts, references), with the box and a wide Gaussian filter, split off the tile grid.

#include "common/image/image.h"
#include "common/scene_io/scene_loader.h"
#include "common/texture/texture.h"
#include "tests/support/test_support.h"
#include "trace/bvh/scene_bvh.h"
#include "trace/raytrace/distributed.h"
#include "trace/raytrace/whitted.h"

#include <gtest/gtest.h>

#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace mrt {
namespace {

constexpr int kWidth = 45;
constexpr int kHeight = 35;

const Scene& scene() {
    static const Scene s =
        load_scene(std::string(MRT_SOURCE_DIR) + "/data/scenes/two-spheres.json");
    return s;
}

const SceneBvh& bvh() {
    static const SceneBvh b(scene());
    return b;
}

/// The four windows of a split at (sx, sy), off the 16-pixel tile grid.
std::vector<PixelWindow> quarters(int sx, int sy) {
    return {{0, 0, sx, sy}, {sx, 0, kWidth, sy}, {0, sy, sx, kHeight}, {sx, sy, kWidth, kHeight}};
}

using Render = std::function<Image(const RenderOptions&)>;

void expect_crops_paste_to_the_frame(const Render& render, RenderOptions options) {
    options.width = kWidth;
    options.height = kHeight;
    options.quiet = true;
    options.threads = 2;
    const Image full = render(options);
    // Off the tile grid, and on it (where a window's own tiles end at its edge, so what lies
    // beyond, the filter's reach and the adaptive pass's neighbourhood, must be traced too).
    for (const auto& [sx, sy] : {std::pair{17, 13}, std::pair{16, 16}}) {
        Image pasted(kWidth, kHeight);
        for (const PixelWindow& window : quarters(sx, sy)) {
            options.crop = window;
            testing::paste(pasted, render(options), window);
        }
        EXPECT_TRUE(testing::same_bits(full, pasted)) << "split at " << sx << ", " << sy;
    }
}

Render whitted(const WhittedOptions& whitted = {}) {
    return [whitted](const RenderOptions& options) {
        return render_whitted(scene(), bvh(), options, whitted).image;
    };
}

Render distributed(const DistributedOptions& distributed) {
    return [distributed](const RenderOptions& options) {
        return render_distributed(scene(), bvh(), options, distributed).image;
    };
}

TEST(Crop, WhittedCropsPasteToTheFrame) {
    RenderOptions options;
    expect_crops_paste_to_the_frame(whitted(), options);
    options.filter = parse_pixel_filter("gaussian:1");
    expect_crops_paste_to_the_frame(whitted({.spp = 4}), options);
}

TEST(Crop, DistributedCropsPasteToTheFrame) {
    using enum DistributedSampling;
    RenderOptions options;
    // Adaptive: pass 2 reads the 5×5 neighbourhood of pass 1; a loose target so that the
    // counts it decides vary from pixel to pixel rather than all hitting the cap.
    const Render adaptive = distributed({.spp_max = 16, .target_error = 0.1f});
    expect_crops_paste_to_the_frame(adaptive, options);
    options.filter = parse_pixel_filter("gaussian:1");
    expect_crops_paste_to_the_frame(adaptive, options);
    options.filter = PixelFilter::box();
    expect_crops_paste_to_the_frame(distributed({.sampling = Fixed, .spp = 3}), options);
    expect_crops_paste_to_the_frame(distributed({.sampling = Reference, .spp = 8}), options);
}

TEST(Crop, ACropTracesOnlyTheTilesItNeeds) {
    RenderOptions options;
    options.width = 160;
    options.height = 160;
    options.quiet = true;
    options.crop = PixelWindow{32, 32, 48, 48};  // one tile, box filter: that tile alone
    const RenderOutput out = render_whitted(scene(), bvh(), options);
    EXPECT_EQ(out.image.width(), 16);
    EXPECT_EQ(out.image.height(), 16);
    EXPECT_EQ(out.samples, 16u * 16u);
}

}  // namespace
}  // namespace mrt
