#include "common/image/image.h"

#include "common/system/error.h"
#include "tests/support/test_support.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <thread>
#include <vector>

namespace {

namespace fs = std::filesystem;
using mrt::Image;
using mrt::Rgb;

using mrt::testing::error_message;

std::vector<std::string> directory_entries(const fs::path& dir) {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir)) {
        names.push_back(entry.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
}

/// A fresh directory per test; tests may run as parallel processes.
class ImageFileTest : public ::testing::Test {
  protected:
    const fs::path& dir() const { return m_scratch.path(); }

  private:
    mrt::testing::ScratchDirectory m_scratch{"mrt_image_test"};
};

/// Values in [0, 1] that vary in x, y and channel, so swapped axes or channels show up.
Image gradient(int width, int height) {
    Image image(width, height);
    for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) {
            image.set(x, y,
                      Rgb(static_cast<float>(x) / static_cast<float>(width - 1),
                          static_cast<float>(y) / static_cast<float>(height - 1),
                          0.5f + 0.5f * std::sin(0.7f * static_cast<float>(x + 2 * y))));
        }
    }
    return image;
}

// ---- Hand-made PNG files (the tests do not use OpenImageIO directly) ----

std::uint32_t crc32(const std::vector<std::uint8_t>& bytes, std::size_t begin) {
    std::uint32_t crc = 0xffffffffU;
    for (std::size_t i = begin; i < bytes.size(); ++i) {
        crc ^= bytes[i];
        for (int k = 0; k < 8; ++k) {
            crc = (crc >> 1) ^ (0xedb88320U & (0U - (crc & 1U)));
        }
    }
    return ~crc;
}

void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v) {
    for (int shift = 24; shift >= 0; shift -= 8) {
        out.push_back(static_cast<std::uint8_t>(v >> shift));
    }
}

void put_chunk(std::vector<std::uint8_t>& png, const char* type,
               const std::vector<std::uint8_t>& data) {
    put_u32(png, static_cast<std::uint32_t>(data.size()));
    std::vector<std::uint8_t> body(type, type + 4);
    body.insert(body.end(), data.begin(), data.end());
    png.insert(png.end(), body.begin(), body.end());
    put_u32(png, crc32(body, 0));
}

/// An 8-bit PNG of colour type 0 (grey, 1 sample) or 4 (grey + alpha, 2 samples) with the
/// pixel data in one uncompressed deflate block.
void write_grey_png(const fs::path& file, int width, int height, int samples,
                    const std::vector<std::uint8_t>& pixels) {
    std::vector<std::uint8_t> raw;
    for (int y = 0; y < height; ++y) {
        raw.push_back(0);  // filter type: none
        const auto row = pixels.begin() + static_cast<std::ptrdiff_t>(y * width * samples);
        raw.insert(raw.end(), row, row + width * samples);
    }
    std::vector<std::uint8_t> zlib = {0x78, 0x01, 0x01};
    const auto len = static_cast<std::uint16_t>(raw.size());
    zlib.push_back(static_cast<std::uint8_t>(len & 0xff));
    zlib.push_back(static_cast<std::uint8_t>(len >> 8));
    zlib.push_back(static_cast<std::uint8_t>(~len & 0xff));
    zlib.push_back(static_cast<std::uint8_t>((~len >> 8) & 0xff));
    zlib.insert(zlib.end(), raw.begin(), raw.end());
    std::uint32_t a = 1;
    std::uint32_t b = 0;
    for (const std::uint8_t v : raw) {
        a = (a + v) % 65521U;
        b = (b + a) % 65521U;
    }
    put_u32(zlib, (b << 16) | a);

    std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    std::vector<std::uint8_t> ihdr;
    put_u32(ihdr, static_cast<std::uint32_t>(width));
    put_u32(ihdr, static_cast<std::uint32_t>(height));
    ihdr.insert(ihdr.end(), {8, static_cast<std::uint8_t>(samples == 1 ? 0 : 4), 0, 0, 0});
    put_chunk(png, "IHDR", ihdr);
    put_chunk(png, "IDAT", zlib);
    put_chunk(png, "IEND", {});
    std::ofstream(file, std::ios::binary)
        .write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
}

// ---- Image ----

TEST(ImageTest, ConstructorFillsEveryPixel) {
    const Image image(3, 2, Rgb(0.1f, 0.2f, 0.3f));
    EXPECT_EQ(image.data().size(), 18U);
    EXPECT_FALSE(image.empty());
    for (int y = 0; y < 2; ++y) {
        for (int x = 0; x < 3; ++x) {
            EXPECT_TRUE((image.at(x, y) == Rgb(0.1f, 0.2f, 0.3f)).all());
        }
    }
    EXPECT_TRUE(Image(0, 5).empty());
}

TEST(ImageTest, NegativeSizeIsAnError) {
    EXPECT_THROW(Image(-1, 4), mrt::Error);
    EXPECT_THROW(Image(4, -1), mrt::Error);
}

// ---- Round trips ----

TEST_F(ImageFileTest, ExrRoundTripIsExact) {
    Image image = gradient(13, 7);
    // Values outside [0, 1], tiny and huge ones survive a float file unchanged.
    image.set(0, 0, Rgb(-2.5f, 1.0e-30f, 65504.0f * 3.0f));
    image.set(12, 6, Rgb(123.456f, 0.1f, 1.0e7f));
    const fs::path file = dir() / "round.exr";
    mrt::write_image(file, image);
    const Image back = mrt::read_image(file);
    ASSERT_EQ(back.width(), 13);
    ASSERT_EQ(back.height(), 7);
    EXPECT_EQ(back.data(), image.data());
}

TEST_F(ImageFileTest, TiffRoundTripIsExact) {
    Image image = gradient(9, 11);
    image.set(4, 5, Rgb(-1.0f, 7.25f, 3.0e-9f));
    for (const char* name : {"round.tif", "round.TIFF"}) {
        mrt::write_image(dir() / name, image);
        const Image back = mrt::read_image(dir() / name);
        ASSERT_EQ(back.width(), 9);
        ASSERT_EQ(back.height(), 11);
        EXPECT_EQ(back.data(), image.data()) << name;
    }
}

TEST_F(ImageFileTest, HdrRoundTripIsWithinSharedExponentPrecision) {
    Image image = gradient(10, 6);
    image.set(1, 1, Rgb(40.0f, 0.5f, 1000.0f));
    mrt::write_image(dir() / "round.hdr", image);
    const Image back = mrt::read_image(dir() / "round.hdr");
    ASSERT_EQ(back.width(), 10);
    ASSERT_EQ(back.height(), 6);
    for (int y = 0; y < 6; ++y) {
        for (int x = 0; x < 10; ++x) {
            // RGBE keeps an 8-bit mantissa relative to the largest channel of the pixel.
            const Rgb a = image.at(x, y);
            const float bound = a.maxCoeff() / 128.0f + 1e-6f;
            EXPECT_TRUE(((back.at(x, y) - a).abs() <= bound).all()) << x << "," << y;
        }
    }
}

TEST_F(ImageFileTest, PngRoundTripIsWithinEightBitSrgbQuantisation) {
    const Image image = gradient(32, 16);
    const fs::path file = dir() / "round.png";
    mrt::write_image(file, image);
    const Image back = mrt::read_image(file);
    ASSERT_EQ(back.width(), 32);
    ASSERT_EQ(back.height(), 16);
    // The encoded value is off by at most half a code h; the linear error is at most h times the
    // steepest slope of the decoding curve on [e − h, e + h] (the slope grows with e).
    constexpr double h = 0.5 / 255.0;
    for (std::size_t i = 0; i < image.data().size(); ++i) {
        const double l = image.data()[i];
        const double e = mrt::linear_to_srgb(image.data()[i]);
        const double top = std::min(e + h, 1.0);
        const double slope =
            std::max(1.0 / 12.92, 2.4 / 1.055 * std::pow((top + 0.055) / 1.055, 1.4));
        EXPECT_NEAR(back.data()[i], l, slope * h + 1e-6) << "sample " << i;
    }
    EXPECT_LT(std::abs(back.data()[0]), 1e-7f);
}

TEST_F(ImageFileTest, PngClampsOutOfRangeValues) {
    Image image(2, 1);
    image.set(0, 0, Rgb(-0.5f, 2.0f, 1.0f));
    image.set(1, 0, Rgb(1.0e9f, -1.0e-9f, 0.0f));
    mrt::write_image(dir() / "clamp.png", image);
    const Image back = mrt::read_image(dir() / "clamp.png");
    EXPECT_TRUE(back.at(0, 0).isApprox(Rgb(0.0f, 1.0f, 1.0f)));
    EXPECT_TRUE(back.at(1, 0).isApprox(Rgb(1.0f, 0.0f, 0.0f)));
}

TEST_F(ImageFileTest, JpegRoundTripOfAFlatColourIsClose) {
    const Rgb colour(0.2f, 0.5f, 0.05f);
    for (const char* name : {"flat.jpg", "flat.jpeg"}) {
        mrt::write_image(dir() / name, Image(16, 16, colour));
        const Image back = mrt::read_image(dir() / name);
        ASSERT_EQ(back.width(), 16);
        for (int y = 0; y < 16; ++y) {
            for (int x = 0; x < 16; ++x) {
                // Lossy, but a flat block decodes to within a couple of codes.
                EXPECT_TRUE(((back.at(x, y) - colour).abs() < 0.02f).all()) << name;
            }
        }
    }
}

std::string file_bytes(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST_F(ImageFileTest, TheSameImageIsTheSameBytesWhenWrittenLater) {
    // The OpenEXR and TIFF writers stamp the time by default (whole seconds), so the second
    // writing comes more than a second after the first.
    const Image image = gradient(7, 5);
    const std::vector<std::string> extensions = {".exr", ".tif",  ".tiff", ".png",
                                                 ".jpg", ".jpeg", ".hdr"};
    for (const std::string& extension : extensions) {
        mrt::write_image(dir() / ("first" + extension), image);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1100));
    for (const std::string& extension : extensions) {
        mrt::write_image(dir() / ("second" + extension), image);
        const std::string first = file_bytes(dir() / ("first" + extension));
        EXPECT_FALSE(first.empty()) << extension;
        EXPECT_TRUE(first == file_bytes(dir() / ("second" + extension))) << extension;
    }
}

TEST_F(ImageFileTest, OverwritingReplacesTheFile) {
    const fs::path file = dir() / "over.exr";
    mrt::write_image(file, Image(4, 4, Rgb(1.0f, 2.0f, 3.0f)));
    mrt::write_image(file, Image(2, 3, Rgb(4.0f, 5.0f, 6.0f)));
    const Image back = mrt::read_image(file);
    EXPECT_EQ(back.width(), 2);
    EXPECT_EQ(back.height(), 3);
    EXPECT_TRUE((back.at(1, 2) == Rgb(4.0f, 5.0f, 6.0f)).all());
    EXPECT_EQ(directory_entries(dir()), std::vector<std::string>{"over.exr"});
}

TEST_F(ImageFileTest, NonFiniteValuesAreNeverWritten) {
    constexpr float nan = std::numeric_limits<float>::quiet_NaN();
    constexpr float inf = std::numeric_limits<float>::infinity();
    Image image(3, 2, Rgb(0.25f, 0.5f, 0.75f));
    image.set(0, 0, Rgb(nan, 0.5f, 0.5f));
    image.set(1, 0, Rgb(inf, -inf, 0.5f));
    image.set(2, 1, Rgb(nan, nan, nan));
    for (const char* name : {"bad.exr", "bad.tif", "bad.hdr", "bad.png"}) {
        mrt::write_image(dir() / name, image);
        const Image back = mrt::read_image(dir() / name);
        for (const float v : back.data()) {
            EXPECT_TRUE(std::isfinite(v)) << name;
        }
        EXPECT_NEAR(back.at(0, 0)[0], 0.0f, 1e-7f) << name;
        EXPECT_NEAR(back.at(1, 0)[0], 0.0f, 1e-7f) << name;
        EXPECT_NEAR(back.at(1, 0)[1], 0.0f, 1e-7f) << name;
        EXPECT_NEAR(back.at(2, 1).abs().maxCoeff(), 0.0f, 1e-7f) << name;
        EXPECT_NEAR(back.at(0, 1)[2], 0.75f, 0.01f) << name;
    }
}

// ---- Failures ----

TEST_F(ImageFileTest, UnknownExtensionNamesTheFileAndWritesNothing) {
    const fs::path file = dir() / "picture.bmpx";
    const std::string message = error_message([&] { mrt::write_image(file, gradient(4, 4)); });
    EXPECT_EQ(message.rfind(file.string() + ": ", 0), 0U) << message;
    EXPECT_NE(message.find(".bmpx"), std::string::npos) << message;
    EXPECT_NE(message.find(".exr"), std::string::npos) << message;
    EXPECT_NE(message.find(".png"), std::string::npos) << message;
    EXPECT_TRUE(directory_entries(dir()).empty());

    EXPECT_THROW(mrt::write_image(dir() / "no_extension", gradient(4, 4)), mrt::Error);
    EXPECT_TRUE(directory_entries(dir()).empty());
}

TEST_F(ImageFileTest, MissingDirectoryNamesTheFileAndWritesNothing) {
    const fs::path file = dir() / "missing" / "out.png";
    const std::string message = error_message([&] { mrt::write_image(file, gradient(4, 4)); });
    EXPECT_EQ(message.rfind(file.string() + ": ", 0), 0U) << message;
    EXPECT_NE(message.find("does not exist"), std::string::npos) << message;
    EXPECT_TRUE(directory_entries(dir()).empty());
}

TEST_F(ImageFileTest, ParentThatIsAFileNamesTheFileAndWritesNothing) {
    std::ofstream(dir() / "plain") << "x";
    const fs::path file = dir() / "plain" / "out.exr";
    const std::string message = error_message([&] { mrt::write_image(file, gradient(4, 4)); });
    EXPECT_EQ(message.rfind(file.string() + ": ", 0), 0U) << message;
    EXPECT_EQ(directory_entries(dir()), std::vector<std::string>{"plain"});
}

TEST_F(ImageFileTest, FailedRenameRemovesTheTemporaryFile) {
    // The image itself is written fine; only moving it onto a directory fails.
    const fs::path file = dir() / "taken.png";
    fs::create_directory(file);
    fs::create_directory(file / "keep");
    const std::string message = error_message([&] { mrt::write_image(file, gradient(4, 4)); });
    EXPECT_EQ(message.rfind(file.string() + ": ", 0), 0U) << message;
    EXPECT_EQ(directory_entries(dir()), std::vector<std::string>{"taken.png"});
}

TEST_F(ImageFileTest, EmptyImageIsAnError) {
    const fs::path file = dir() / "empty.exr";
    const std::string message = error_message([&] { mrt::write_image(file, Image()); });
    EXPECT_EQ(message.rfind(file.string() + ": ", 0), 0U) << message;
    EXPECT_TRUE(directory_entries(dir()).empty());
}

TEST_F(ImageFileTest, ReadingAMissingFileNamesIt) {
    const fs::path file = dir() / "nothing.exr";
    const std::string message = error_message([&] { mrt::read_image(file); });
    EXPECT_EQ(message.rfind(file.string() + ": ", 0), 0U) << message;
    EXPECT_NE(message.find("no such file"), std::string::npos) << message;
}

TEST_F(ImageFileTest, ReadingGarbageNamesTheFile) {
    for (const char* name : {"garbage.png", "garbage.exr", "garbage.unknown"}) {
        const fs::path file = dir() / name;
        std::ofstream(file) << "this is not an image, just some text\n";
        const std::string message = error_message([&] { mrt::read_image(file); });
        EXPECT_EQ(message.rfind(file.string() + ": ", 0), 0U) << message;
        EXPECT_GT(message.size(), file.string().size() + 2) << message;
    }
}

// ---- Channel layouts ----

TEST_F(ImageFileTest, GreyPngIsExpandedToLinearRgb) {
    const fs::path file = dir() / "grey.png";
    write_grey_png(file, 3, 2, 1, {0, 128, 255, 10, 200, 64});
    const Image back = mrt::read_image(file);
    ASSERT_EQ(back.width(), 3);
    ASSERT_EQ(back.height(), 2);
    const std::uint8_t codes[] = {0, 128, 255, 10, 200, 64};
    for (int i = 0; i < 6; ++i) {
        const float expected = mrt::srgb_to_linear(static_cast<float>(codes[i]) / 255.0f);
        const Rgb c = back.at(i % 3, i / 3);
        EXPECT_NEAR(c[0], expected, 1e-6f) << i;
        EXPECT_EQ(c[0], c[1]);
        EXPECT_EQ(c[0], c[2]);
    }
}

TEST_F(ImageFileTest, GreyAlphaPngDropsAlphaWithoutPremultiplying) {
    const fs::path file = dir() / "grey_alpha.png";
    write_grey_png(file, 2, 1, 2, {128, 64, 255, 0});
    const Image back = mrt::read_image(file);
    ASSERT_EQ(back.width(), 2);
    ASSERT_EQ(back.height(), 1);
    EXPECT_TRUE(back.at(0, 0).isApprox(Rgb::Constant(mrt::srgb_to_linear(128.0f / 255.0f)), 1e-5f));
    EXPECT_TRUE(back.at(1, 0).isApprox(Rgb::Constant(1.0f), 1e-5f));
}

// ---- sRGB curve ----

TEST(SrgbCurve, KnownValues) {
    EXPECT_NEAR(mrt::linear_to_srgb(0.5f), 0.735357f, 1e-6f);
    EXPECT_NEAR(mrt::srgb_to_linear(0.5f), 0.214041f, 1e-6f);
    EXPECT_EQ(mrt::linear_to_srgb(0.0f), 0.0f);
    EXPECT_EQ(mrt::srgb_to_linear(0.0f), 0.0f);
    EXPECT_NEAR(mrt::linear_to_srgb(1.0f), 1.0f, 1e-7f);
    EXPECT_NEAR(mrt::srgb_to_linear(1.0f), 1.0f, 1e-7f);
    // The linear segment: slope 12.92.
    EXPECT_FLOAT_EQ(mrt::linear_to_srgb(0.001f), 0.01292f);
    EXPECT_FLOAT_EQ(mrt::srgb_to_linear(0.01292f), 0.001f);
}

TEST(SrgbCurve, IsContinuousAtTheSegmentJoints) {
    const float knee = 0.0031308f;
    const float below = mrt::linear_to_srgb(knee);
    const float above = mrt::linear_to_srgb(std::nextafter(knee, 1.0f));
    EXPECT_NEAR(below, 0.04045f, 1e-6f);
    EXPECT_NEAR(above, below, 1e-6f);

    const float encoded_knee = 0.04045f;
    EXPECT_NEAR(mrt::srgb_to_linear(std::nextafter(encoded_knee, 1.0f)),
                mrt::srgb_to_linear(encoded_knee), 1e-7f);
}

TEST(SrgbCurve, RoundTripsAndIsMonotonic) {
    float previous = -1.0f;
    for (int i = 0; i <= 4096; ++i) {
        const float l = static_cast<float>(i) / 4096.0f;
        const float e = mrt::linear_to_srgb(l);
        EXPECT_NEAR(mrt::srgb_to_linear(e), l, 1e-6f + 1e-6f * l) << l;
        EXPECT_GT(e, previous);
        previous = e;
    }
}

}  // namespace

namespace mrt {
namespace {

TEST(ImageOutputCheck, RefusesWhatWriteImageWouldRefuseBeforeAnyWork) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "mrt_check_output";
    std::filesystem::create_directories(dir);
    EXPECT_NO_THROW(check_image_output(dir / "ok.png"));
    EXPECT_NO_THROW(check_image_output(dir / "ok.exr"));
    EXPECT_THROW(check_image_output(dir / "bad.xyz"), Error);
    EXPECT_THROW(check_image_output(dir / "missing" / "x.png"), Error);
    std::filesystem::create_directories(dir / "taken.png");
    EXPECT_EQ(testing::error_message([&] { check_image_output(dir / "taken.png"); }),
              (dir / "taken.png").string() + ": cannot write image: is a directory");
    EXPECT_FALSE(std::filesystem::exists(dir / "ok.png"));
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace mrt
