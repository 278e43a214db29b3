// Texture lookups against an independent bilinear reconstruction of a tiny image, and the
// footprint filters (Igehy 1999 §4) against averages known by construction.

#include "common/texture/texture.h"
#include "common/image/image.h"
#include "tests/support/leaf_texture.h"
#include "tests/support/test_support.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

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

TEST(TextureSampler, OpacityIsTheAlphaChannelOrAGreyMaskAsStoredFilteredOverTheFootprint) {
    const testing::ScratchDirectory scratch("mrt_texture_test_opacity");
    const double inside = testing::write_leaf_texture(scratch.path() / "leaf.png", 64);
    // A grey mask of 8-bit 128 (write_image encodes PNGs as sRGB): read as stored, 128/255,
    // where linearising would give 0.216.
    Image grey(4, 4);
    for (int y = 0; y < 4; ++y) {
        for (int x = 0; x < 4; ++x) {
            grey.set(x, y, Rgb::Constant(srgb_to_linear(128.0f / 255.0f)));
        }
    }
    write_image(scratch.path() / "grey.png", grey);
    Scene scene;
    scene.textures.push_back(Texture{scratch.path() / "leaf.png", false, TextureChannel::Opacity});
    scene.textures.push_back(Texture{scratch.path() / "grey.png", false, TextureChannel::Opacity});
    scene.textures.push_back(Texture{scratch.path() / "leaf.png", true, TextureChannel::Colour});
    const TextureSampler sampler(scene, TextureFilter::Trilinear);
    Material leaf;
    leaf.opacity_texture = 0;
    EXPECT_FLOAT_EQ(sampler.opacity(leaf, Vec2f(0.5f, 0.5f)), 1.0f) << "the leaf's middle";
    EXPECT_FLOAT_EQ(sampler.opacity(leaf, Vec2f(0.03f, 0.03f)), 0.0f) << "a corner";
    // A footprint as wide as the texture reads the top of the box-filtered pyramid: the mean
    // alpha, the share of the texels inside the leaf.
    const UvFootprint whole{Vec2f(1.0f, 0.0f), Vec2f(0.0f, 1.0f)};
    EXPECT_NEAR(sampler.opacity(leaf, Vec2f(0.5f, 0.5f), whole), inside, 2e-3);
    Material masked;
    masked.opacity_texture = 1;
    EXPECT_NEAR(sampler.opacity(masked, Vec2f(0.3f, 0.6f)), 128.0f / 255.0f, 1e-3f);
    EXPECT_FLOAT_EQ(sampler.opacity(Material{}, Vec2f(0.3f, 0.6f)), 1.0f) << "no cut-out";
    // The same file as colour: its RGB, linearised, alpha ignored.
    const Rgb colour = sampler.lookup(2, Vec2f(0.5f, 0.5f));
    EXPECT_NEAR(colour[1], srgb_to_linear(160.0f / 255.0f), 1e-3f);
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

// ---- Footprint filters ----------------------------------------------------------------------

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr TextureFilter kAllFilters[] = {TextureFilter::None, TextureFilter::Distance,
                                         TextureFilter::Trilinear, TextureFilter::Anisotropic};
constexpr TextureFilter kMipMappedFilters[] = {TextureFilter::Distance, TextureFilter::Trilinear,
                                               TextureFilter::Anisotropic};

/// Black/white checker `size`² of square checks `check` texels wide; the top-left texel is white.
Image checker(int size, int check) {
    Image image(size, size);
    for (int y = 0; y < size; ++y) {
        for (int x = 0; x < size; ++x) {
            const float value = (x / check + y / check) % 2 == 0 ? 1.0f : 0.0f;
            image.set(x, y, Rgb(value, value, value));
        }
    }
    return image;
}

/// Vertical black/white stripes one texel wide: even columns white.
Image stripes(int size) {
    Image image(size, size);
    for (int y = 0; y < size; ++y) {
        for (int x = 0; x < size; ++x) {
            const float value = x % 2 == 0 ? 1.0f : 0.0f;
            image.set(x, y, Rgb(value, value, value));
        }
    }
    return image;
}

/// uv of the point `x` texels from the left and `y` texels from the top of a `size`² texture.
Vec2f uv_at(float x, float y, int size) {
    const auto n = static_cast<float>(size);
    return {x / n, 1.0f - y / n};
}

/// Isotropic footprint `texels` texels wide on a `size`-texel-wide texture.
UvFootprint isotropic(float texels, int size) {
    const float w = texels / static_cast<float>(size);
    return {Vec2f(w, 0.0f), Vec2f(0.0f, w)};
}

/// A fresh directory per test; tests may run as parallel processes.
class TextureFiltering : public ::testing::Test {
  protected:
    const fs::path& dir() const { return m_scratch.path(); }

    /// Writes `image` as `name` (.png: 8-bit sRGB; .exr: linear float) into a texture of `scene`.
    void add_texture(Scene& scene, const Image& image, const std::string& name, bool srgb) const {
        write_image(dir() / name, image);
        scene.textures.push_back(Texture{dir() / name, srgb});
    }

  private:
    mrt::testing::ScratchDirectory m_scratch{"mrt_texture_filter_test"};
};

TEST(TextureFilterNames, EveryNameParsesBackToItself) {
    for (const TextureFilter filter : kAllFilters) {
        EXPECT_EQ(parse_texture_filter(to_string(filter)), filter);
    }
    EXPECT_EQ(parse_texture_filter("none"), TextureFilter::None);
    EXPECT_EQ(parse_texture_filter("distance"), TextureFilter::Distance);
    EXPECT_EQ(parse_texture_filter("trilinear"), TextureFilter::Trilinear);
    EXPECT_EQ(parse_texture_filter("anisotropic"), TextureFilter::Anisotropic);
    std::ostringstream os;
    os << TextureFilter::Anisotropic << " " << UvFootprint{Vec2f(1.0f, 2.0f), Vec2f(3.0f, 4.0f)};
    EXPECT_EQ(os.str(), "anisotropic UvFootprint{duv_dx (1, 2), duv_dy (3, 4)}");
}

TEST(TextureFilterNames, UnknownNameIsRefusedWithTheChoices) {
    EXPECT_EQ(testing::error_message([] { parse_texture_filter("Trilinear"); }),
              "texture filter: found \"Trilinear\", expected none, distance, trilinear or "
              "anisotropic");
    EXPECT_EQ(testing::error_message([] { parse_texture_filter(""); }),
              "texture filter: found \"\", expected none, distance, trilinear or anisotropic");
}

TEST_F(TextureFiltering, NoneIgnoresTheFootprintAndIsTheUnfilteredBilinearLookup) {
    Image img(5, 4);
    for (int y = 0; y < 4; ++y) {
        for (int x = 0; x < 5; ++x) {
            img.set(x, y,
                    Rgb(0.1f * static_cast<float>(x), 0.2f * static_cast<float>(y),
                        0.5f + 0.4f * std::sin(static_cast<float>(x + 3 * y))));
        }
    }
    Scene scene;
    add_texture(scene, img, "tex.exr", false);
    const TextureSampler none(scene, TextureFilter::None);
    const TextureSampler trilinear(scene, TextureFilter::Trilinear);
    EXPECT_EQ(none.filter(), TextureFilter::None);
    EXPECT_EQ(trilinear.filter(), TextureFilter::Trilinear);
    const UvFootprint footprints[] = {
        {},
        isotropic(3.0f, 5),
        {Vec2f(0.7f, 0.1f), Vec2f(-0.02f, 0.01f)},
        {Vec2f(kNaN, 0.0f), Vec2f(0.0f, 0.1f)},
    };
    for (float u : {0.0f, 0.3f, 0.5f, 0.77f, 1.4f, -0.2f}) {
        for (float v : {0.0f, 0.25f, 0.6f, 0.98f}) {
            const Rgb unfiltered = none.lookup(0, Vec2f(u, v));
            const Rgb want = reference_bilinear(img, u, v);
            // The footprint-free overload is the None filter whatever the sampler's filter.
            const Rgb same = trilinear.lookup(0, Vec2f(u, v));
            for (int c = 0; c < 3; ++c) {
                EXPECT_NEAR(unfiltered[c], want[c], 2e-3f) << "uv " << u << "," << v;
                EXPECT_EQ(same[c], unfiltered[c]) << "uv " << u << "," << v;
            }
            for (const UvFootprint& footprint : footprints) {
                const Rgb got = none.lookup(0, Vec2f(u, v), footprint);
                for (int c = 0; c < 3; ++c) {
                    EXPECT_EQ(got[c], unfiltered[c]) << "uv " << u << "," << v << " " << footprint;
                }
            }
        }
    }
}

TEST_F(TextureFiltering, SrgbTexelsAreLinearisedBeforeInterpolation) {
    // Two columns 0.2 and 0.8 (linear): halfway between the texel centres the lookup is their
    // linear mean 0.5. Interpolating the encoded values first would give 0.47.
    Image img(2, 1);
    img.set(0, 0, Rgb(0.2f, 0.2f, 0.2f));
    img.set(1, 0, Rgb(0.8f, 0.8f, 0.8f));
    Scene scene;
    add_texture(scene, img, "tex.png", true);
    // The independent reference: the 8-bit file decoded by read_image, bilinear in linear RGB.
    const Image decoded = read_image(dir() / "tex.png");
    const TextureSampler sampler(scene);
    for (float u : {0.25f, 0.4f, 0.5f, 0.6f, 0.75f, 0.9f}) {
        const Rgb got = sampler.lookup(0, Vec2f(u, 0.5f));
        const Rgb want = reference_bilinear(decoded, u, 0.5f);
        // Half floats hold the linear values to a relative 2^-11.
        EXPECT_NEAR(got[0], want[0], 1e-3f) << "u " << u;
    }
    EXPECT_NEAR(sampler.lookup(0, Vec2f(0.5f, 0.5f))[0], 0.5f, 5e-3f);
}

TEST_F(TextureFiltering, FineCheckerUnderAWideFootprintAveragesToHalfExceptUnfiltered) {
    constexpr int kSize = 256;
    Scene scene;
    add_texture(scene, checker(kSize, 1), "checker.png", true);
    const float w = 16.0f / kSize;
    const float r = w / std::sqrt(2.0f);
    const UvFootprint footprints[] = {
        isotropic(16.0f, kSize),
        {Vec2f(r, r), Vec2f(-r, r)},  // the same square, rotated 45°
        {Vec2f(w, 0.0f), Vec2f(0.0f, 0.5f * w)},
    };
    const TextureSampler none(scene, TextureFilter::None);
    const TextureSampler distance(scene, TextureFilter::Distance);
    const TextureSampler trilinear(scene, TextureFilter::Trilinear);
    const TextureSampler anisotropic(scene, TextureFilter::Anisotropic);
    for (int y : {3, 100, 201}) {
        for (int x : {0, 17, 128, 255}) {
            const float x_f = static_cast<float>(x) + 0.5f;
            const float y_f = static_cast<float>(y) + 0.5f;
            const Vec2f uv = uv_at(x_f, y_f, kSize);
            const float texel = (x + y) % 2 == 0 ? 1.0f : 0.0f;
            for (const UvFootprint& footprint : footprints) {
                // Unfiltered: the texel itself, 0 or 1, however much of the texture the pixel
                // covers (Igehy Fig. 3a's aliasing).
                EXPECT_NEAR(none.lookup(0, uv, footprint)[0], texel, 1e-6f);
                for (const TextureSampler* sampler : {&distance, &trilinear, &anisotropic}) {
                    EXPECT_NEAR(sampler->lookup(0, uv, footprint)[0], 0.5f, 0.02f)
                        << sampler->filter() << " at texel " << x << "," << y << " " << footprint;
                }
            }
        }
    }
}

TEST_F(TextureFiltering, SrgbCheckerMinifiedToOneTexelAveragesLinearHalf) {
    // Half the texels encode 0 and half 255: the light they reflect averages to linear 0.5.
    // Averaging the encoded values and then decoding would give sRGB 0.5 = linear 0.214.
    constexpr int kSize = 256;
    Scene scene;
    add_texture(scene, checker(kSize, 1), "checker.png", true);
    const UvFootprint whole{Vec2f(1.0f, 0.0f), Vec2f(0.0f, 1.0f)};
    for (const TextureFilter filter : kMipMappedFilters) {
        const TextureSampler sampler(scene, filter);
        for (const Vec2f& uv : {Vec2f(0.3f, 0.7f), Vec2f(0.5f, 0.5f), Vec2f(0.01f, 0.99f)}) {
            const Rgb c = sampler.lookup(0, uv, whole);
            for (int ch = 0; ch < 3; ++ch) {
                EXPECT_NEAR(c[ch], 0.5f, 0.01f) << filter << " channel " << ch;
            }
        }
    }
}

TEST_F(TextureFiltering, AnisotropicAveragesTheMajorAxisAndKeepsTheMinorAxisSharp) {
    // One-texel vertical stripes; the point is the centre of a white column.
    constexpr int kSize = 256;
    Scene scene;
    add_texture(scene, stripes(kSize), "stripes.png", true);
    const TextureSampler trilinear(scene, TextureFilter::Trilinear);
    const TextureSampler anisotropic(scene, TextureFilter::Anisotropic);
    const Vec2f uv = uv_at(100.5f, 77.5f, kSize);
    const float major = 8.0f / kSize;  // aspect 16: exactly the cap
    const float minor = 0.5f / kSize;

    // Footprint long across the stripes: both filters average them.
    const UvFootprint across{Vec2f(major, 0.0f), Vec2f(0.0f, minor)};
    EXPECT_NEAR(anisotropic.lookup(0, uv, across)[0], 0.5f, 0.1f);
    EXPECT_NEAR(trilinear.lookup(0, uv, across)[0], 0.5f, 0.05f);

    // Footprint long along the stripes: the anisotropic filter stays within the white column;
    // the isotropic one blurs over the minor axis as much as over the major one (Igehy §4.1).
    const UvFootprint along{Vec2f(minor, 0.0f), Vec2f(0.0f, major)};
    const float sharp = anisotropic.lookup(0, uv, along)[0];
    const float blurred = trilinear.lookup(0, uv, along)[0];
    EXPECT_NEAR(sharp, 1.0f, 0.05f);
    EXPECT_NEAR(blurred, 0.5f, 0.05f);
    EXPECT_LT(std::abs(blurred - 0.5f), std::abs(sharp - 0.5f));
}

TEST_F(TextureFiltering, AnisotropicRespondsToSinusoidsLikeTheBoxOverTheParallelogram) {
    // A pixel's footprint is the parallelogram of its derivatives; averaging a sinusoid of
    // period P over a box w texels long scales its amplitude by sinc(w/P). The anisotropic
    // filter must follow that along the major and the minor axis; OpenImageIO's elliptical
    // filter given the derivatives unscaled would miss by 0.15 RMS over these cases, and the
    // isotropic one (as wide as the major axis) loses the detail across it.
    constexpr int kSize = 512;
    const double periods[] = {32.0, 64.0, 128.0};
    Scene scene;
    for (const bool along_u : {true, false}) {
        for (const double period : periods) {
            Image image(kSize, kSize);
            for (int y = 0; y < kSize; ++y) {
                for (int x = 0; x < kSize; ++x) {
                    const double c = (along_u ? x : y) + 0.5;
                    const auto v = static_cast<float>(0.5 + 0.5 * std::sin(2.0 * kPi * c / period));
                    image.set(x, y, Rgb(v, v, v));
                }
            }
            add_texture(scene, image, fmt::format("sine-{}-{}.exr", along_u ? "u" : "v", period),
                        false);
        }
    }
    const TextureSampler anisotropic(scene, TextureFilter::Anisotropic);
    const TextureSampler trilinear(scene, TextureFilter::Trilinear);
    const auto amplitude = [&](const TextureSampler& sampler, int texture, bool along_u,
                               double period, const UvFootprint& footprint) {
        double low = 1.0, high = 0.0;
        for (int i = 0; i < 2 * static_cast<int>(period); ++i) {
            const float c = 100.0f + 0.5f * static_cast<float>(i);
            const Vec2f uv = along_u ? uv_at(c, 200.0f, kSize) : uv_at(200.0f, c, kSize);
            const double v = sampler.lookup(texture, uv, footprint)[0];
            low = std::min(low, v);
            high = std::max(high, v);
        }
        return high - low;
    };
    double sum_anisotropic = 0.0, sum_trilinear = 0.0;
    int count = 0;
    for (const auto& [major, minor] :
         {std::pair{16.0, 1.0}, std::pair{32.0, 4.0}, std::pair{24.0, 3.0}, std::pair{8.0, 8.0}}) {
        const UvFootprint footprint{Vec2f(static_cast<float>(major / kSize), 0.0f),
                                    Vec2f(0.0f, static_cast<float>(minor / kSize))};
        int texture = 0;
        for (const bool along_u : {true, false}) {
            for (const double period : periods) {
                const double w = along_u ? major : minor;
                const double box = std::sin(kPi * w / period) / (kPi * w / period);
                const double a = amplitude(anisotropic, texture, along_u, period, footprint);
                const double t = amplitude(trilinear, texture, along_u, period, footprint);
                EXPECT_NEAR(a, box, 0.2) << major << "×" << minor << " texels, period " << period
                                         << (along_u ? " along the major axis" : " across");
                sum_anisotropic += (a - box) * (a - box);
                sum_trilinear += (t - box) * (t - box);
                ++count;
                ++texture;
            }
        }
    }
    const double rms_anisotropic = std::sqrt(sum_anisotropic / count);
    const double rms_trilinear = std::sqrt(sum_trilinear / count);
    EXPECT_LT(rms_anisotropic, 0.09) << "trilinear " << rms_trilinear;
    EXPECT_LT(rms_anisotropic, 0.5 * rms_trilinear);
}

TEST_F(TextureFiltering, AnisotropyBeyondTheCapWidensTheMinorAxis) {
    // Aspect 256 along the stripes: capped at kMaxAnisotropy by widening the minor axis to
    // 128 / 16 = 8 texels (6 after the filter's scale), which averages the one-texel stripes
    // (blurred rather than aliased).
    static_assert(TextureSampler::kMaxAnisotropy == 16.0f);
    constexpr int kSize = 256;
    Scene scene;
    add_texture(scene, stripes(kSize), "stripes.png", true);
    const TextureSampler anisotropic(scene, TextureFilter::Anisotropic);
    const UvFootprint along{Vec2f(0.5f / kSize, 0.0f), Vec2f(0.0f, 128.0f / kSize)};
    EXPECT_NEAR(anisotropic.lookup(0, uv_at(100.5f, 77.5f, kSize), along)[0], 0.5f, 0.05f);
}

TEST_F(TextureFiltering, DerivativesFollowVUpLikeTheCoordinates) {
    // Bands 8 texels wide along the image's anti-diagonals (x + y constant, y down), i.e. along
    // +u+v in uv space where v points up. A footprint along +u+v stays inside a band; one along
    // +u−v crosses two bands. Getting the sign of the v derivatives wrong swaps the two.
    constexpr int kSize = 256;
    Image bands(kSize, kSize);
    for (int y = 0; y < kSize; ++y) {
        for (int x = 0; x < kSize; ++x) {
            const float value = ((x + y) / 8) % 2 == 0 ? 1.0f : 0.0f;
            bands.set(x, y, Rgb(value, value, value));
        }
    }
    Scene scene;
    add_texture(scene, bands, "bands.png", true);
    const TextureSampler sampler(scene, TextureFilter::Anisotropic);
    // Texel centres with x + y = 8·4 + 3 and 8·5 + 3: the middle of a white and a black band.
    const float a = 8.0f / kSize / std::sqrt(2.0f);       // major axis: 8 texels
    const float b = 0.5f / kSize / std::sqrt(2.0f);       // minor axis: half a texel
    const UvFootprint along{Vec2f(a, a), Vec2f(b, -b)};   // +u+v
    const UvFootprint across{Vec2f(a, -a), Vec2f(b, b)};  // +u−v
    for (const auto& [x, y, value] : {std::tuple{20, 15, 1.0f}, std::tuple{30, 13, 0.0f}}) {
        const Vec2f uv = uv_at(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f, kSize);
        ASSERT_EQ(sampler.lookup(0, uv)[0], value);
        EXPECT_NEAR(sampler.lookup(0, uv, along)[0], value, 0.05f) << x << "," << y;
        EXPECT_NEAR(sampler.lookup(0, uv, across)[0], 0.5f, 0.15f) << x << "," << y;
    }
}

TEST_F(TextureFiltering, TrilinearWidthIsTheLongerDerivativeWhateverItsDirection) {
    // Eq. 26: the level of detail depends on the derivatives' lengths only. A square footprint 8
    // texels wide turned by 45° is as wide as the unturned one, and averages the 4-texel checks
    // at their centres to 0.5 (per-axis extents would see 5.7 texels and keep most contrast).
    constexpr int kSize = 256;
    Scene scene;
    add_texture(scene, checker(kSize, 4), "checker.png", true);
    const TextureSampler sampler(scene, TextureFilter::Trilinear);
    const Vec2f centre = uv_at(4.0f * 7.0f + 2.0f, 4.0f * 9.0f + 2.0f, kSize);
    for (float texels : {3.0f, 6.0f, 8.0f}) {
        const float r = texels / kSize / std::sqrt(2.0f);
        const UvFootprint turned{Vec2f(r, r), Vec2f(-r, r)};
        const UvFootprint longer_y{Vec2f(0.5f * r, 0.0f), Vec2f(r, r)};
        const float want = sampler.lookup(0, centre, isotropic(texels, kSize))[0];
        EXPECT_NEAR(sampler.lookup(0, centre, turned)[0], want, 1e-4f) << texels;
        EXPECT_NEAR(sampler.lookup(0, centre, longer_y)[0], want, 1e-4f) << texels;
    }
    EXPECT_NEAR(sampler.lookup(0, centre, isotropic(8.0f, kSize))[0], 0.5f, 0.02f);
}

TEST_F(TextureFiltering, UvScaleOfFourFiltersAFourTimesWiderFootprint) {
    // Checks 4 texels wide, sampled at a check's centre through a footprint 2 texels wide on the
    // mesh: the unscaled material keeps the check's value; scaled by 4 the footprint is 8 texels,
    // two checks, which average to 0.5 — and scaled by 8, 16 texels, four checks.
    constexpr int kSize = 256;
    Scene scene;
    add_texture(scene, checker(kSize, 4), "checker.png", true);
    Material plain;
    plain.diffuse = Rgb(1.0f, 1.0f, 1.0f);
    plain.texture = 0;
    Material tiled = plain;
    tiled.uv_transform = Affine2f(Eigen::Scaling(4.0f, 4.0f));
    Material finer = plain;
    finer.uv_transform = Affine2f(Eigen::Scaling(8.0f, 8.0f));
    const UvFootprint footprint = isotropic(2.0f, kSize);
    for (const TextureFilter filter : kMipMappedFilters) {
        const TextureSampler sampler(scene, filter);
        for (const auto& [i, j] : {std::pair{5, 9}, std::pair{12, 12}, std::pair{40, 3}}) {
            const Vec2f centre = uv_at(4.0f * static_cast<float>(i) + 2.0f,
                                       4.0f * static_cast<float>(j) + 2.0f, kSize);
            const float check = (i + j) % 2 == 0 ? 1.0f : 0.0f;
            EXPECT_NEAR(sampler.diffuse(plain, centre, footprint)[0], check, 1e-3f) << filter;
            // centre / 4 on the mesh is `centre` in the tiled texture.
            const Vec2f mesh_uv = 0.25f * centre;
            if (filter != TextureFilter::Anisotropic) {
                EXPECT_NEAR(sampler.diffuse(tiled, mesh_uv, footprint)[0], 0.5f, 0.02f) << filter;
            }
            // The anisotropic filter is narrower (no wider than the pixel's footprint, see
            // AnisotropicRespondsToSinusoids...): twice the footprint averages it as well.
            EXPECT_NEAR(sampler.diffuse(finer, 0.125f * centre, footprint)[0], 0.5f, 0.05f)
                << filter;
            // Exactly a lookup through the transformed coordinates and derivatives.
            const UvFootprint scaled{4.0f * footprint.duv_dx, 4.0f * footprint.duv_dy};
            EXPECT_EQ(sampler.diffuse(tiled, mesh_uv, footprint)[0],
                      sampler.lookup(0, tiled.uv_transform * mesh_uv, scaled)[0]);
        }
    }
    // A material without a texture is its diffuse colour, footprint or not.
    Material flat;
    flat.diffuse = Rgb(0.1f, 0.2f, 0.3f);
    const TextureSampler sampler(scene, TextureFilter::Anisotropic);
    EXPECT_TRUE((sampler.diffuse(flat, Vec2f(0.5f, 0.5f), footprint) == flat.diffuse).all());
}

TEST_F(TextureFiltering, UvRotationTurnsTheFootprintWithTheTexture) {
    // A footprint long along mesh u lies across the stripes unrotated (averaged), and along them
    // once the uv transform turns it by 90° (kept sharp by the anisotropic filter).
    constexpr int kSize = 256;
    Scene scene;
    add_texture(scene, stripes(kSize), "stripes.png", true);
    const TextureSampler sampler(scene, TextureFilter::Anisotropic);
    Material plain;
    plain.diffuse = Rgb(1.0f, 1.0f, 1.0f);
    plain.texture = 0;
    Material turned = plain;
    turned.uv_transform = Affine2f(Eigen::Rotation2Df(0.5f * kPi));
    const UvFootprint along_u{Vec2f(8.0f / kSize, 0.0f), Vec2f(0.0f, 0.5f / kSize)};
    const Vec2f target = uv_at(100.5f, 77.5f, kSize);  // a white column's centre
    EXPECT_NEAR(sampler.diffuse(plain, target, along_u)[0], 0.5f, 0.1f);
    // Rotation by 90° maps (u, v) to (−v, u): mesh (v, −u) lands on the target.
    const Vec2f mesh_uv(target.y(), -target.x());
    ASSERT_LT((turned.uv_transform * mesh_uv - target).norm(), 1e-6f);
    EXPECT_NEAR(sampler.diffuse(turned, mesh_uv, along_u)[0], 1.0f, 0.05f);
}

TEST_F(TextureFiltering, NonFiniteHugeTinyOrCollinearDerivativesGiveFiniteColours) {
    constexpr int kSize = 256;
    Scene scene;
    add_texture(scene, checker(kSize, 1), "checker.png", true);
    const float big = std::numeric_limits<float>::max();
    const float d = 4.0f / kSize;
    const UvFootprint unusual[] = {
        {Vec2f(kNaN, 0.0f), Vec2f(0.0f, d)},
        {Vec2f(d, 0.0f), Vec2f(kInf, 0.0f)},
        {Vec2f(-kInf, kNaN), Vec2f(kNaN, -kInf)},
        {Vec2f(1e30f, 0.0f), Vec2f(0.0f, -1e30f)},
        {Vec2f(big, big), Vec2f(-big, big)},
        {Vec2f(big, 0.0f), Vec2f(0.0f, 0.0f)},
        {Vec2f(1e-30f, 0.0f), Vec2f(0.0f, 1e-30f)},
        {Vec2f(1e-30f, 1e-30f), Vec2f(1e-30f, 1e-30f)},
        {Vec2f(d, d), Vec2f(d, d)},  // collinear
        {Vec2f(d, d), Vec2f(-2.0f * d, -2.0f * d)},
        {Vec2f(d, 0.0f), Vec2f(0.0f, 0.0f)},
    };
    const Vec2f uvs[] = {Vec2f(0.3f, 0.6f), Vec2f(kNaN, 0.5f), Vec2f(0.5f, kInf),
                         Vec2f(1e30f, -1e30f)};
    for (const TextureFilter filter : kAllFilters) {
        const TextureSampler sampler(scene, filter);
        for (const Vec2f& uv : uvs) {
            for (const UvFootprint& footprint : unusual) {
                const Rgb c = sampler.lookup(0, uv, footprint);
                EXPECT_TRUE(c.allFinite() && (c >= 0.0f).all() && (c <= 1.0f).all())
                    << filter << " uv (" << uv.x() << ", " << uv.y() << ") " << footprint
                    << " gave " << c.transpose();
            }
        }
        // An unknown (non-finite) footprint is a point sample.
        const Vec2f uv = uv_at(77.5f, 30.5f, kSize);
        EXPECT_EQ(sampler.lookup(0, uv, unusual[0])[0], sampler.lookup(0, uv, UvFootprint{})[0])
            << filter;
        // A footprint larger than the texture averages all of it.
        if (filter != TextureFilter::None) {
            for (int k : {3, 4}) {
                EXPECT_NEAR(sampler.lookup(0, uv, unusual[k])[0], 0.5f, 0.01f) << filter << k;
            }
        }
    }
}

TEST_F(TextureFiltering, LookupsFromManyThreadsAgreeWithOneThread) {
    constexpr int kSize = 64;
    Scene scene;
    add_texture(scene, checker(kSize, 3), "checker.png", true);
    add_texture(scene, stripes(kSize), "stripes.exr", false);
    const TextureSampler trilinear(scene, TextureFilter::Trilinear);
    const TextureSampler anisotropic(scene, TextureFilter::Anisotropic);
    struct Query {
        int texture;
        Vec2f uv;
        UvFootprint footprint;
    };
    std::vector<Query> queries;
    for (int k = 0; k < 200; ++k) {
        const auto f = static_cast<float>(k);
        queries.push_back({k % 2,
                           Vec2f(0.013f * f, 0.7f - 0.021f * f),
                           {Vec2f(0.001f * static_cast<float>(k % 17), 0.002f),
                            Vec2f(-0.003f, 0.0005f * static_cast<float>(k % 29))}});
    }
    std::vector<float> want;
    for (const Query& q : queries) {
        want.push_back(trilinear.lookup(q.texture, q.uv, q.footprint)[0]);
        want.push_back(anisotropic.lookup(q.texture, q.uv, q.footprint)[0]);
    }
    std::atomic<int> mismatches{0};
    std::vector<std::thread> threads;
    for (int t = 0; t < 8; ++t) {
        threads.emplace_back([&] {
            for (int repeat = 0; repeat < 5; ++repeat) {
                for (std::size_t k = 0; k < queries.size(); ++k) {
                    const Query& q = queries[k];
                    // Alternate samplers, so each thread switches between their OIIO states.
                    if (trilinear.lookup(q.texture, q.uv, q.footprint)[0] != want[2 * k] ||
                        anisotropic.lookup(q.texture, q.uv, q.footprint)[0] != want[2 * k + 1]) {
                        ++mismatches;
                    }
                }
            }
        });
    }
    for (std::thread& thread : threads) {
        thread.join();
    }
    EXPECT_EQ(mismatches.load(), 0);
}

TEST_F(TextureFiltering, MipMapsLiveInATemporaryDirectoryRemovedWithTheSampler) {
    Scene scene;
    add_texture(scene, checker(16, 1), "checker.png", true);
    const fs::path tmp = dir() / "tmp";
    fs::create_directories(tmp);
    const char* old = std::getenv("TMPDIR");
    const std::string saved = old != nullptr ? old : "";
    ::setenv("TMPDIR", tmp.c_str(), 1);
    {
        const TextureSampler sampler(scene, TextureFilter::Trilinear);
        int entries = 0;
        for (const auto& entry : fs::directory_iterator(tmp)) {
            EXPECT_EQ(entry.path().filename().string().rfind("mrt-textures-", 0), 0u)
                << entry.path();
            ++entries;
        }
        EXPECT_EQ(entries, 1);
    }
    EXPECT_TRUE(fs::is_empty(tmp));
    if (old != nullptr) {
        ::setenv("TMPDIR", saved.c_str(), 1);
    } else {
        ::unsetenv("TMPDIR");
    }
}

/// A directory set as $TMPDIR for the test's lifetime, then restored.
class TemporaryTmpdir {
  public:
    explicit TemporaryTmpdir(fs::path dir) : m_dir(std::move(dir)) {
        fs::create_directories(m_dir);
        const char* old = std::getenv("TMPDIR");
        m_had_old = old != nullptr;
        m_old = m_had_old ? old : "";
        ::setenv("TMPDIR", m_dir.c_str(), 1);
    }
    ~TemporaryTmpdir() {
        if (m_had_old) {
            ::setenv("TMPDIR", m_old.c_str(), 1);
        } else {
            ::unsetenv("TMPDIR");
        }
    }
    TemporaryTmpdir(const TemporaryTmpdir&) = delete;
    TemporaryTmpdir& operator=(const TemporaryTmpdir&) = delete;

  private:
    fs::path m_dir;
    bool m_had_old = false;
    std::string m_old;
};

std::vector<std::string> entry_names(const fs::path& dir) {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir)) {
        names.push_back(entry.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
}

/// The id of a process that has exited and been reaped, so that no process has it (until the
/// system hands it out again, which takes a full cycle of process ids).
pid_t dead_pid() {
    const pid_t child = ::fork();
    if (child == 0) {
        ::_exit(0);
    }
    int status = 0;
    ::waitpid(child, &status, 0);
    return child;
}

TEST_F(TextureFiltering, SweepsTheMipMapDirectoriesOfProcessesThatNoLongerExist) {
    Scene scene;
    add_texture(scene, checker(8, 1), "checker.png", true);
    const fs::path tmp = dir() / "tmp";
    const TemporaryTmpdir tmpdir(tmp);
    const std::string dead = fmt::format("mrt-textures-{}-a1b2c3", dead_pid());
    const std::string live = fmt::format("mrt-textures-{}-d4e5f6", ::getppid());
    const std::string old_style = "mrt-textures-123456";
    const std::string not_a_directory = fmt::format("mrt-textures-{}-file", dead_pid());
    for (const std::string& name : {dead, live, old_style}) {
        fs::create_directories(tmp / name);
        std::ofstream(tmp / name / "0.tif") << "mip-map";
    }
    std::ofstream(tmp / not_a_directory) << "not ours";
    {
        const TextureSampler sampler(scene, TextureFilter::Trilinear);
        const std::vector<std::string> names = entry_names(tmp);
        EXPECT_EQ(std::count(names.begin(), names.end(), dead), 0);
        EXPECT_EQ(names.size(), 4u);
    }
    const std::vector<std::string> left = {live, old_style, not_a_directory};
    std::vector<std::string> expected = left;
    std::sort(expected.begin(), expected.end());
    EXPECT_EQ(entry_names(tmp), expected);
}

/// Rewrites the size in a PNG's IHDR chunk (and the chunk's CRC), leaving the data as it was.
void set_png_size(const fs::path& file, std::uint32_t width, std::uint32_t height) {
    std::fstream io(file, std::ios::in | std::ios::out | std::ios::binary);
    std::vector<unsigned char> ihdr(17);  // "IHDR" and its 13 bytes of data
    io.seekg(12);
    io.read(reinterpret_cast<char*>(ihdr.data()), 17);
    for (int k = 0; k < 4; ++k) {
        ihdr[static_cast<std::size_t>(4 + k)] = static_cast<unsigned char>(width >> (24 - 8 * k));
        ihdr[static_cast<std::size_t>(8 + k)] = static_cast<unsigned char>(height >> (24 - 8 * k));
    }
    std::uint32_t crc = 0xffffffffU;
    for (const unsigned char byte : ihdr) {
        crc ^= byte;
        for (int bit = 0; bit < 8; ++bit) {
            crc = (crc >> 1) ^ (0xedb88320U & (0U - (crc & 1U)));
        }
    }
    crc = ~crc;
    for (int k = 0; k < 4; ++k) {
        ihdr.push_back(static_cast<unsigned char>(crc >> (24 - 8 * k)));
    }
    io.seekp(12);
    io.write(reinterpret_cast<const char*>(ihdr.data()), static_cast<std::streamsize>(ihdr.size()));
}

TEST_F(TextureFiltering, TextureOverThePixelBudgetIsRefusedFromItsHeader) {
    Scene scene;
    add_texture(scene, checker(4, 1), "huge.png", true);
    set_png_size(scene.textures[0].path, 65535, 65535);
    const std::string file = scene.textures[0].path.string();
    // Its 4.3e9 pixels would need 51 GB as floats; the header alone decides.
    EXPECT_EQ(testing::error_message([&] { const TextureSampler sampler(scene); }),
              file +
                  ": the scene asks for 4.29e+09 pixels (a 65535×65535 texture), over the "
                  "limit of 2.68e+08 (raise it with --budget pixels=N)");

    Scene small;
    add_texture(small, checker(4, 1), "small.png", true);
    Budgets budgets;
    budgets.pixels = 15;
    EXPECT_EQ(testing::error_message(
                  [&] { const TextureSampler sampler(small, TextureFilter::None, budgets); }),
              small.textures[0].path.string() +
                  ": the scene asks for 16 pixels (a 4×4 texture), over the limit of 15 (raise it "
                  "with --budget pixels=N)");
    budgets.pixels = 16;
    EXPECT_NO_THROW(const TextureSampler sampler(small, TextureFilter::None, budgets));
}

TEST_F(TextureFiltering, AFullDiskWhileMipMappingIsAWriteFailureOfTheDirectory) {
    Scene scene;
    add_texture(scene, checker(256, 3), "big.exr", false);
    const fs::path tmp = dir() / "tmp";
    const TemporaryTmpdir tmpdir(tmp);
    // A file size limit fails the mip-map's writes as a full disk would (EFBIG instead of
    // ENOSPC), without filling one; SIGXFSZ ignored so the write returns the error. The limit is
    // well below the mip-map's size: 16 KiB was reached in the Release build (19 KiB written
    // before the failure) but not in the Debug build under ASan (17 KiB written in all, with
    // TIFF's rewrites, and no failure).
    struct rlimit saved {};
    ::getrlimit(RLIMIT_FSIZE, &saved);
    const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
    struct rlimit limited = saved;
    limited.rlim_cur = 4096;
    ::setrlimit(RLIMIT_FSIZE, &limited);
    const std::string message =
        testing::error_message([&] { const TextureSampler sampler(scene); });
    ::setrlimit(RLIMIT_FSIZE, &saved);
    std::signal(SIGXFSZ, old_handler);

    const std::string prefix = (tmp / "mrt-textures-").string();
    const std::string suffix = ": cannot write the mip-map of texture '" +
                               scene.textures[0].path.string() + "': File too large";
    EXPECT_EQ(message.rfind(prefix, 0), 0u) << message;
    ASSERT_GE(message.size(), suffix.size()) << message;
    EXPECT_EQ(message.substr(message.size() - suffix.size()), suffix) << message;
    EXPECT_TRUE(fs::is_empty(tmp));
}

}  // namespace
}  // namespace mrt
