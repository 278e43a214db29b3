// Texture lookups against an independent bilinear reconstruction of a tiny image.

#include "common/texture.h"
#include "common/image.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

namespace mrt {
namespace {

namespace fs = std::filesystem;

/// Bilinear interpolation with periodic wrap; texel (i, j) centred at ((i+.5)/w, (j+.5)/h) in
/// (s, t) with t = 0 the top row, and t = 1 − v.
Rgb reference_bilinear(const Image& img, float u, float v) {
    const float s = u * static_cast<float>(img.width()) - 0.5f;
    const float t = (1.0f - v) * static_cast<float>(img.height()) - 0.5f;
    const float fs = std::floor(s);
    const float ft = std::floor(t);
    const float ws = s - fs;
    const float wt = t - ft;
    const auto wrap = [](int i, int n) { return ((i % n) + n) % n; };
    const auto texel = [&](int i, int j) {
        return img.at(wrap(i, img.width()), wrap(j, img.height()));
    };
    const int i = static_cast<int>(fs);
    const int j = static_cast<int>(ft);
    return (1 - ws) * (1 - wt) * texel(i, j) + ws * (1 - wt) * texel(i + 1, j) +
           (1 - ws) * wt * texel(i, j + 1) + ws * wt * texel(i + 1, j + 1);
}

TEST(TextureSampler, BilinearLookupMatchesAnIndependentReconstruction) {
    const fs::path dir = fs::temp_directory_path() / "mrt_texture_test";
    fs::create_directories(dir);
    Image img(3, 2);
    img.set(0, 0, Rgb(1.0f, 0.0f, 0.0f));
    img.set(1, 0, Rgb(0.0f, 1.0f, 0.0f));
    img.set(2, 0, Rgb(0.0f, 0.0f, 1.0f));
    img.set(0, 1, Rgb(0.5f, 0.5f, 0.5f));
    img.set(1, 1, Rgb(0.25f, 0.75f, 0.125f));
    img.set(2, 1, Rgb(0.9f, 0.1f, 0.3f));
    write_image(dir / "tex.exr", img);

    Scene scene;
    scene.textures.push_back(Texture{dir / "tex.exr", false});
    const TextureSampler sampler(scene);
    for (float u : {0.0f, 1.0f / 6.0f, 0.3f, 0.5f, 0.77f, 0.99f, 1.4f, -0.2f}) {
        for (float v : {0.0f, 0.25f, 0.6f, 0.75f, 0.98f}) {
            const Rgb got = sampler.lookup(0, Vec2f(u, v));
            const Rgb want = reference_bilinear(img, u, v);
            for (int c = 0; c < 3; ++c) {
                EXPECT_NEAR(got[c], want[c], 2e-3f) << "uv " << u << "," << v;
            }
        }
    }
    // Texel centre of the top-left texel: exact.
    const Rgb corner = sampler.lookup(0, Vec2f(1.0f / 6.0f, 0.75f));
    EXPECT_NEAR(corner[0], 1.0f, 1e-5f);
    fs::remove_all(dir);
}

TEST(TextureSampler, MaterialDiffuseIsColourTimesTextureThroughTheUvTransform) {
    const fs::path dir = fs::temp_directory_path() / "mrt_texture_test_uv";
    fs::create_directories(dir);
    Image img(2, 1);
    img.set(0, 0, Rgb(0.2f, 0.4f, 0.8f));
    img.set(1, 0, Rgb(1.0f, 1.0f, 1.0f));
    write_image(dir / "tex.exr", img);
    Scene scene;
    scene.textures.push_back(Texture{dir / "tex.exr", false});
    const TextureSampler sampler(scene);
    Material m;
    m.diffuse = Rgb(0.5f, 0.5f, 0.5f);
    m.texture = 0;
    // Scale u by 0.5: u = 0.5 on the mesh samples texel 0's centre (u = 0.25).
    m.uv_transform = Affine2f(Eigen::Scaling(0.5f, 1.0f));
    const Rgb d = sampler.diffuse(m, Vec2f(0.5f, 0.5f));
    EXPECT_NEAR(d[0], 0.1f, 1e-5f);
    EXPECT_NEAR(d[1], 0.2f, 1e-5f);
    EXPECT_NEAR(d[2], 0.4f, 1e-5f);
    fs::remove_all(dir);
}

TEST(TextureSampler, UnreadableTextureIsRefusedWithItsName) {
    Scene scene;
    scene.textures.push_back(Texture{"/nonexistent/texture-that-is-not-there.png", true});
    try {
        const TextureSampler sampler(scene);
        FAIL() << "expected an error";
    } catch (const std::exception& e) {
        EXPECT_NE(std::string(e.what()).find("texture-that-is-not-there.png"), std::string::npos)
            << e.what();
    }
}

}  // namespace
}  // namespace mrt
