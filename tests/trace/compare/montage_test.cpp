#include "trace/compare/montage.h"

#include "common/system/error.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

namespace {

using mrt::Image;
using mrt::kMontageBackground;
using mrt::kMontageLabelHeight;
using mrt::kMontageMargin;
using mrt::make_montage;
using mrt::MontageCell;
using mrt::MontageOptions;
using mrt::Rgb;
using mrt::testing::error_message;

const Rgb kRed(1.0f, 0.0f, 0.0f);
const Rgb kGreen(0.0f, 1.0f, 0.0f);
const Rgb kBlue(0.0f, 0.0f, 1.0f);
const Rgb kBackground = Rgb::Constant(kMontageBackground);

bool font_installed() {
    return std::filesystem::is_regular_file(mrt::kDejaVuSansPath);
}

/// Left edge of column `c` for cells `cell_width` wide (the header's formula).
int column_x(int c, int cell_width) {
    return kMontageMargin + c * (cell_width + kMontageMargin);
}

/// A pixel-by-pixel comparison that names the first pixel that differs.
::testing::AssertionResult same_pixels(const Image& a, const Image& b) {
    if (a.width() != b.width() || a.height() != b.height()) {
        return ::testing::AssertionFailure() << "sizes differ: " << a.width() << "×" << a.height()
                                             << " vs " << b.width() << "×" << b.height();
    }
    for (int y = 0; y < a.height(); ++y) {
        for (int x = 0; x < a.width(); ++x) {
            if ((a.at(x, y) != b.at(x, y)).any()) {
                return ::testing::AssertionFailure()
                       << "pixel (" << x << ", " << y << ") is " << a.at(x, y).transpose()
                       << ", expected " << b.at(x, y).transpose();
            }
        }
    }
    return ::testing::AssertionSuccess();
}

/// Number of pixels in [x0, x1) × [y0, y1) that are not exactly the background.
int non_background_pixels(const Image& image, int x0, int y0, int x1, int y1) {
    int count = 0;
    for (int y = y0; y < y1; ++y) {
        for (int x = x0; x < x1; ++x) {
            if ((image.at(x, y) != kBackground).any()) {
                ++count;
            }
        }
    }
    return count;
}

TEST(MontageLayout, SizeFollowsTheFormula) {
    // cell_width 32: 64×32 → 32×16, 32×64 → 32×64, 10×10 → 32×32.
    const std::vector<MontageCell> cells = {
        {Image(64, 32, kRed), "a"}, {Image(32, 64, kGreen), "b"}, {Image(10, 10, kBlue), "c"}};
    const Image montage = make_montage(cells, 2, 32);
    // 2 columns: 2·32 + 3·8 = 88. Rows: max(16, 64) + 24 = 88 and 32 + 24 = 56, plus 3·8.
    EXPECT_EQ(montage.width(), 88);
    EXPECT_EQ(montage.height(), 88 + 56 + 24);
}

TEST(MontageLayout, ColumnsBeyondTheCellCountAreNotReserved) {
    const std::vector<MontageCell> cells = {{Image(4, 4, kRed), ""}, {Image(4, 4, kGreen), ""}};
    const Image montage = make_montage(cells, 5, 16);
    EXPECT_EQ(montage.width(), 2 * 16 + 3 * 8);
    EXPECT_EQ(montage.height(), 16 + 24 + 2 * 8);
}

TEST(MontageLayout, ScaledHeightIsRoundedAndAtLeastOnePixel) {
    // 3×2 at width 16: 16·2/3 = 10.67 → 11. 1000×1 at width 16: 0.016 → 0, kept at 1.
    EXPECT_EQ(make_montage({{Image(3, 2, kRed), ""}}, 1, 16).height(), 11 + 24 + 16);
    EXPECT_EQ(make_montage({{Image(1000, 1, kRed), ""}}, 1, 16).height(), 1 + 24 + 16);
}

TEST(MontageCells, UniformImagesFillTheirCellsAndNothingElse) {
    const int w = 32;
    // Row 0: red 10×5 (→ 32×16) and green 7×7 (→ 32×32); row 1: blue 4×8 (→ 32×64).
    const std::vector<MontageCell> cells = {
        {Image(10, 5, kRed), ""}, {Image(7, 7, kGreen), ""}, {Image(4, 8, kBlue), ""}};
    const Image montage = make_montage(cells, 2, w);

    // Expected picture, built from the documented layout: row 0 is 32 + 24 tall.
    const int row1_y = kMontageMargin + 32 + kMontageLabelHeight + kMontageMargin;
    Image expected(2 * w + 3 * kMontageMargin, row1_y + 64 + kMontageLabelHeight + kMontageMargin,
                   kBackground);
    const auto fill = [&](int x0, int y0, int width, int height, const Rgb& c) {
        for (int y = y0; y < y0 + height; ++y) {
            for (int x = x0; x < x0 + width; ++x) {
                expected.set(x, y, c);
            }
        }
    };
    fill(column_x(0, w), kMontageMargin, w, 16, kRed);
    fill(column_x(1, w), kMontageMargin, w, 32, kGreen);
    fill(column_x(0, w), row1_y, w, 64, kBlue);
    // Empty labels draw nothing; the unused slot at row 1, column 1 stays background.
    EXPECT_TRUE(same_pixels(montage, expected));
}

TEST(MontageScaling, GrowingRepeatsSourcePixels) {
    Image image(2, 1);
    image.set(0, 0, kRed);
    image.set(1, 0, kBlue);
    const Image montage = make_montage({{image, ""}}, 1, 16);  // 2×1 → 16×8
    for (int y = 0; y < 8; ++y) {
        for (int x = 0; x < 16; ++x) {
            const Rgb expected = x < 8 ? kRed : kBlue;
            EXPECT_TRUE((montage.at(kMontageMargin + x, kMontageMargin + y) == expected).all())
                << "at (" << x << ", " << y << ")";
        }
    }
}

TEST(MontageScaling, ShrinkingAveragesTheCoveredArea) {
    // A ramp 24 px wide, value = column index, shrunk to 16 px: every output pixel covers 1.5
    // source pixels. Reference: the mean of the step function floor(t) over the covered
    // interval, integrated numerically.
    const int source_width = 24;
    Image image(source_width, 3);
    for (int y = 0; y < 3; ++y) {
        for (int x = 0; x < source_width; ++x) {
            image.set(x, y, Rgb::Constant(static_cast<float>(x)));
        }
    }
    const Image montage = make_montage({{image, ""}}, 1, 16);  // → 16×2
    const double scale = source_width / 16.0;
    for (int o = 0; o < 16; ++o) {
        const int steps = 30000;
        double sum = 0.0;
        for (int k = 0; k < steps; ++k) {
            sum += std::floor((o + (k + 0.5) / steps) * scale);
        }
        const double reference = sum / steps;
        for (int y = 0; y < 2; ++y) {
            EXPECT_NEAR(montage.at(kMontageMargin + o, kMontageMargin + y)[1], reference, 1e-3)
                << "output column " << o;
        }
    }
}

TEST(MontageScaling, ShrinkingAStripePatternGivesItsMean) {
    // Every third column white: shrinking 48 → 16 averages exactly one white and two black.
    Image image(48, 3);
    for (int x = 0; x < 48; ++x) {
        image.set(x, 0, Rgb::Constant(x % 3 == 0 ? 1.0f : 0.0f));
        image.set(x, 1, image.at(x, 0));
        image.set(x, 2, image.at(x, 0));
    }
    const Image montage = make_montage({{image, ""}}, 1, 16);  // → 16×1
    for (int x = 0; x < 16; ++x) {
        EXPECT_NEAR(montage.at(kMontageMargin + x, kMontageMargin)[0], 1.0f / 3.0f, 1e-6f);
    }
}

TEST(MontageLabels, TextIsDrawnInTheStripUnderItsCell) {
    if (!font_installed()) {
        GTEST_SKIP() << mrt::kDejaVuSansPath << " is not installed (fonts-dejavu-core)";
    }
    const int w = 128;
    const Image montage =
        make_montage({{Image(8, 4, kRed), "Reference"}, {Image(8, 4, kGreen), ""}}, 2, w);
    const int strip_y = kMontageMargin + 64;
    EXPECT_GT(non_background_pixels(montage, column_x(0, w), strip_y, column_x(0, w) + w,
                                    strip_y + kMontageLabelHeight),
              20);
    // The text is light on the dark background.
    float brightest = 0.0f;
    for (int y = strip_y; y < strip_y + kMontageLabelHeight; ++y) {
        for (int x = column_x(0, w); x < column_x(0, w) + w; ++x) {
            brightest = std::max(brightest, montage.at(x, y).minCoeff());
        }
    }
    EXPECT_GT(brightest, 0.5f);
    // The other cell's label is empty: its strip is untouched, and so is the red image.
    EXPECT_EQ(non_background_pixels(montage, column_x(1, w), strip_y, column_x(1, w) + w,
                                    strip_y + kMontageLabelHeight),
              0);
    for (int y = kMontageMargin; y < strip_y; ++y) {
        for (int x = column_x(0, w); x < column_x(0, w) + w; ++x) {
            ASSERT_TRUE((montage.at(x, y) == kRed).all()) << "at (" << x << ", " << y << ")";
        }
    }
}

TEST(MontageLabels, LongLabelsStayInsideTheirColumn) {
    if (!font_installed()) {
        GTEST_SKIP() << mrt::kDejaVuSansPath << " is not installed (fonts-dejavu-core)";
    }
    std::string long_ascii(300, 'W');
    std::string long_utf8;
    for (int i = 0; i < 150; ++i) {
        long_utf8 += "\xC3\xA9\xE2\x86\x92";  // "é→": multi-byte code points to cut between
    }
    for (const int w : {16, 40, 256}) {
        for (const std::string& label :
             {long_ascii, long_utf8, std::string("two\nlines\tand a tab")}) {
            const Image montage = make_montage(
                {{Image(4, 4, kRed), ""}, {Image(4, 4, kGreen), label}, {Image(4, 4, kBlue), ""}},
                3, w);
            const int x0 = column_x(1, w);
            const int strip_y = kMontageMargin + w;
            // Everything left and right of the middle column is exactly what it is without text.
            const Image unlabelled = make_montage(
                {{Image(4, 4, kRed), ""}, {Image(4, 4, kGreen), ""}, {Image(4, 4, kBlue), ""}}, 3,
                w);
            ASSERT_EQ(montage.width(), unlabelled.width());
            ASSERT_EQ(montage.height(), unlabelled.height());
            for (int y = 0; y < montage.height(); ++y) {
                for (int x = 0; x < montage.width(); ++x) {
                    const bool in_middle_strip =
                        x >= x0 && x < x0 + w && y >= strip_y && y < strip_y + kMontageLabelHeight;
                    if (!in_middle_strip) {
                        ASSERT_TRUE((montage.at(x, y) == unlabelled.at(x, y)).all())
                            << "label of width " << w << " drew at (" << x << ", " << y << ")";
                    }
                }
            }
            if (w >= 40) {
                // Wide enough for a few characters and the ellipsis: something is drawn, and
                // the cut keeps it off the strip's outermost columns.
                EXPECT_GT(non_background_pixels(montage, x0, strip_y, x0 + w,
                                                strip_y + kMontageLabelHeight),
                          0);
                EXPECT_EQ(non_background_pixels(montage, x0, strip_y, x0 + 1,
                                                strip_y + kMontageLabelHeight),
                          0);
                EXPECT_EQ(non_background_pixels(montage, x0 + w - 1, strip_y, x0 + w,
                                                strip_y + kMontageLabelHeight),
                          0);
            }
        }
    }
}

/// The label strip of a one-cell montage with `label`.
Image label_strip(const std::string& label) {
    const int w = 64;
    const Image montage = make_montage({{Image(4, 4, kRed), label}}, 1, w);
    Image strip(w, kMontageLabelHeight);
    for (int y = 0; y < kMontageLabelHeight; ++y) {
        for (int x = 0; x < w; ++x) {
            strip.set(x, y, montage.at(kMontageMargin + x, kMontageMargin + w + y));
        }
    }
    return strip;
}

TEST(MontageLabels, NonAsciiIsNeverDrawnAsAnUnrelatedAsciiGlyph) {
    if (!font_installed()) {
        GTEST_SKIP() << mrt::kDejaVuSansPath << " is not installed (fonts-dejavu-core)";
    }
    // OpenImageIO 2.4 decodes U+00E9 as 0x29 ')' and U+2026 as 0x26 '&'; whichever way the
    // installed version goes (real glyphs, or the ASCII stand-ins), those must not appear.
    EXPECT_FALSE(same_pixels(label_strip("\xC3\xA9"), label_strip(")")));
    EXPECT_FALSE(same_pixels(label_strip("\xE2\x80\xA6"), label_strip("&")));
    EXPECT_FALSE(same_pixels(label_strip("\xC3\x97"), label_strip("\x17")));
    EXPECT_GT(non_background_pixels(label_strip("\xC3\xA9"), 0, 0, 64, kMontageLabelHeight), 0);
}

TEST(MontageLabels, MissingFontLaysOutWithoutTextAndWarnsOnce) {
    const std::vector<MontageCell> labelled = {{Image(8, 8, kRed), "Reference"},
                                               {Image(8, 8, kGreen), "Error"}};
    const std::vector<MontageCell> unlabelled = {{Image(8, 8, kRed), ""},
                                                 {Image(8, 8, kGreen), ""}};
    MontageOptions options;
    options.cell_width = 64;
    options.fonts = {"/nonexistent/NoSuchFont.ttf", "NoSuchFontName"};
    std::vector<std::string> warnings;
    options.warn = [&](const std::string& message) { warnings.push_back(message); };

    const Image montage = make_montage(labelled, 2, options);
    EXPECT_TRUE(same_pixels(montage, make_montage(unlabelled, 2, 64)));
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("/nonexistent/NoSuchFont.ttf"), std::string::npos) << warnings[0];
}

TEST(MontageErrors, BadArgumentsThrowWithTheReason) {
    const std::vector<MontageCell> one = {{Image(4, 4, kRed), "x"}};
    EXPECT_EQ(error_message([&] { make_montage(one, 0); }),
              "make_montage: columns must be at least 1, got 0");
    EXPECT_EQ(error_message([&] { make_montage(one, 1, 15); }),
              "make_montage: cell_width must be at least 16 px, got 15");
    EXPECT_EQ(error_message([&] { make_montage({}, 1); }),
              "make_montage: no cells to lay out (the cell list is empty)");
    EXPECT_EQ(error_message([&] {
                  make_montage({{Image(4, 4, kRed), "a"}, {Image(), "b"}}, 2);
              }),
              "make_montage: cell 1 (label \"b\") has an empty image (0×0)");
    EXPECT_THROW(make_montage({{Image(1, 100000, kRed), ""}}, 1, 4096), mrt::Error);
}

}  // namespace
