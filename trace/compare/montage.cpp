#include "trace/compare/montage.h"

#include "common/system/error.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/strutil.h>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace mrt {

namespace {

constexpr int kMinCellWidth = 16;
/// Free space kept between a label and the sides of its cell, in pixels.
constexpr int kLabelPadding = 3;
/// U+2026 HORIZONTAL ELLIPSIS in UTF-8 (DejaVu Sans has the glyph), and what stands for it
/// when OpenImageIO cannot draw non-ASCII text.
constexpr const char* kEllipsis = "\xE2\x80\xA6";
constexpr const char* kAsciiEllipsis = "...";

/// How label text reaches OpenImageIO's text drawing.
enum class Glyphs : std::uint8_t {
    Ascii,    ///< Non-ASCII text replaced (an OpenImageIO that garbles UTF-8).
    Unicode,  ///< As written.
};

// ---------------------------------------------------------------------------------------------
// Scaling

/// One source pixel's share of an output pixel along one axis.
struct Tap {
    int source;
    float weight;
};

/// For every output index along an axis of `source_size` pixels scaled to `output_size`, the
/// source pixels it reads. Shrinking averages the source interval the output pixel covers, each
/// source pixel weighted by the length it overlaps (a box filter, so noise is averaged rather
/// than aliased); growing takes the source pixel under the output pixel's centre, which keeps
/// the pixels of small error images visible as squares instead of blurring them.
std::vector<std::vector<Tap>> axis_taps(int source_size, int output_size) {
    std::vector<std::vector<Tap>> taps(static_cast<std::size_t>(output_size));
    const double scale = static_cast<double>(source_size) / output_size;
    for (int o = 0; o < output_size; ++o) {
        std::vector<Tap>& out = taps[static_cast<std::size_t>(o)];
        if (scale <= 1.0) {
            const int s = std::min(source_size - 1, static_cast<int>((o + 0.5) * scale));
            out.push_back({s, 1.0f});
            continue;
        }
        const double begin = o * scale;
        const double end = std::min<double>(source_size, (o + 1) * scale);
        const int first = static_cast<int>(begin);
        const int last = std::min(source_size - 1, static_cast<int>(std::ceil(end)) - 1);
        for (int s = first; s <= last; ++s) {
            const double overlap = std::min<double>(end, s + 1) - std::max<double>(begin, s);
            if (overlap > 0.0) {
                out.push_back({s, static_cast<float>(overlap / (end - begin))});
            }
        }
    }
    return taps;
}

/// `image` resampled to width × height, separably (rows first, then columns), in linear RGB.
Image scaled(const Image& image, int width, int height) {
    if (image.width() == width && image.height() == height) {
        return image;
    }
    const std::vector<std::vector<Tap>> x_taps = axis_taps(image.width(), width);
    const std::vector<std::vector<Tap>> y_taps = axis_taps(image.height(), height);

    Image rows(width, image.height());
    for (int y = 0; y < image.height(); ++y) {
        for (int x = 0; x < width; ++x) {
            Rgb sum = Rgb::Zero();
            for (const Tap& t : x_taps[static_cast<std::size_t>(x)]) {
                sum += t.weight * image.at(t.source, y);
            }
            rows.set(x, y, sum);
        }
    }
    Image out(width, height);
    for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) {
            Rgb sum = Rgb::Zero();
            for (const Tap& t : y_taps[static_cast<std::size_t>(y)]) {
                sum += t.weight * rows.at(x, t.source);
            }
            out.set(x, y, sum);
        }
    }
    return out;
}

// ---------------------------------------------------------------------------------------------
// Layout

/// Where everything goes, computed (and checked for size) before any pixel is touched.
struct Layout {
    int columns = 0;
    int width = 0;
    int height = 0;
    /// Per cell: its scaled image height and the top-left corner of its slot.
    std::vector<int> image_heights;
    std::vector<int> x;
    std::vector<int> y;
    /// Per cell: the top of its label strip (under the tallest image of its row).
    std::vector<int> label_y;
};

/// Refuses sizes an Image (int width and height, one allocation) cannot hold.
int checked_dimension(std::int64_t value, const char* what) {
    // Also keeps width·height·3 floats well inside size_t on 64-bit systems.
    constexpr std::int64_t kLimit = std::int64_t{1} << 20;
    if (value > kLimit) {
        throw Error(
            fmt::format("make_montage: the montage would be {} px {}, more than the {} "
                        "px an image may have (fewer columns or a smaller cell_width?)",
                        value, what, kLimit));
    }
    return static_cast<int>(value);
}

Layout compute_layout(const std::vector<MontageCell>& cells, int columns, int cell_width) {
    Layout layout;
    const std::size_t count = cells.size();
    layout.columns =
        static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(columns), count));
    layout.image_heights.resize(count);
    layout.x.resize(count);
    layout.y.resize(count);
    layout.label_y.resize(count);

    for (std::size_t i = 0; i < count; ++i) {
        const Image& image = cells[i].image;
        if (image.empty()) {
            throw Error(
                fmt::format("make_montage: cell {} (label \"{}\") has an empty image ({}×{})", i,
                            cells[i].label, image.width(), image.height()));
        }
        const double h =
            std::round(static_cast<double>(cell_width) * image.height() / image.width());
        layout.image_heights[i] = checked_dimension(
            std::max<std::int64_t>(1, static_cast<std::int64_t>(std::min(h, 1e12))),
            "tall (one cell image's height)");
    }

    const std::int64_t width = static_cast<std::int64_t>(layout.columns) * cell_width +
                               static_cast<std::int64_t>(layout.columns + 1) * kMontageMargin;
    layout.width = checked_dimension(width, "wide");

    const auto columns_z = static_cast<std::size_t>(layout.columns);
    std::int64_t top = kMontageMargin;
    for (std::size_t row_start = 0; row_start < count; row_start += columns_z) {
        const std::size_t row_end = std::min(count, row_start + columns_z);
        const int row_image_height =
            *std::max_element(layout.image_heights.begin() + static_cast<std::ptrdiff_t>(row_start),
                              layout.image_heights.begin() + static_cast<std::ptrdiff_t>(row_end));
        const int row_top = checked_dimension(top, "tall");
        for (std::size_t i = row_start; i < row_end; ++i) {
            const auto column = static_cast<int>(i - row_start);
            layout.x[i] = kMontageMargin + column * (cell_width + kMontageMargin);
            layout.y[i] = row_top;
            layout.label_y[i] = row_top + row_image_height;
        }
        top += row_image_height + kMontageLabelHeight + kMontageMargin;
    }
    layout.height = checked_dimension(top, "tall");
    return layout;
}

// ---------------------------------------------------------------------------------------------
// Labels

/// The first font of `candidates` that FreeType can load and measure text with, if any.
/// text_size reports failure through an undefined ROI and leaves no OpenImageIO error behind.
std::optional<std::string> usable_font(const std::vector<std::string>& candidates) {
    for (const std::string& font : candidates) {
        if (!font.empty() &&
            OIIO::ImageBufAlgo::text_size("Hg", kMontageFontSize, font).defined()) {
            return font;
        }
    }
    return std::nullopt;
}

/// Whether this OpenImageIO turns UTF-8 into the right code points for FreeType. 2.4 (Debian
/// 12) does not: its Strutil::utf8_to_unicode keeps only the low six bits of a multi-byte code
/// point, so "é" (U+00E9) would be drawn as ")" and "…" (U+2026) as "&".
bool oiio_decodes_utf8() {
    static const bool decodes = [] {
        std::vector<std::uint32_t> code_points;
        OIIO::Strutil::utf8_to_unicode("\xC3\xA9\xE2\x80\xA6", code_points);
        return code_points == std::vector<std::uint32_t>{0xE9, 0x2026};
    }();
    return decodes;
}

/// ASCII stand-ins for characters likely in comparison labels, for an OpenImageIO that cannot
/// draw non-ASCII text; any other non-ASCII character becomes "?".
struct AsciiFallback {
    std::string_view utf8;
    std::string_view ascii;
};
constexpr AsciiFallback kAsciiFallbacks[] = {
    {"\xC3\x97", "x"},        // × multiplication sign ("error ×10")
    {"\xC2\xB1", "+/-"},      // ± plus-minus sign
    {"\xE2\x80\x93", "-"},    // – en dash
    {"\xE2\x80\x94", "-"},    // — em dash
    {"\xE2\x80\xA6", "..."},  // … ellipsis
    {"\xE2\x86\x92", "->"},   // → rightwards arrow
};

/// `text` with every non-ASCII code point (a lead byte and its continuation bytes, or a stray
/// byte of malformed UTF-8) replaced by its stand-in.
std::string ascii_text(const std::string& text) {
    std::string out;
    for (std::size_t i = 0; i < text.size();) {
        if (static_cast<unsigned char>(text[i]) < 0x80) {
            out += text[i++];
            continue;
        }
        std::size_t length = 1;
        while (i + length < text.size() &&
               (static_cast<unsigned char>(text[i + length]) & 0xC0) == 0x80) {
            ++length;
        }
        const std::string_view code_point(text.data() + i, length);
        std::string_view replacement = "?";
        for (const AsciiFallback& fallback : kAsciiFallbacks) {
            if (code_point == fallback.utf8) {
                replacement = fallback.ascii;
            }
        }
        out += replacement;
        i += length;
    }
    return out;
}

/// The label as one line that OpenImageIO draws faithfully: control characters (newline would
/// start a second line below the strip, tab has no glyph) become spaces, surrounding spaces are
/// dropped, and non-ASCII text is made ASCII unless the font is drawn as Unicode.
std::string drawable_label(const std::string& label, Glyphs glyphs) {
    std::string text = glyphs == Glyphs::Unicode ? label : ascii_text(label);
    std::replace_if(
        text.begin(), text.end(),
        [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7F; }, ' ');
    const std::size_t first = text.find_first_not_of(' ');
    if (first == std::string::npos) {
        return {};
    }
    const std::size_t last = text.find_last_not_of(' ');
    return text.substr(first, last - first + 1);
}

/// Byte offsets where a UTF-8 code point starts (cutting elsewhere would leave an invalid
/// sequence), after the first code point, plus the end.
std::vector<std::size_t> code_point_ends(const std::string& text) {
    std::vector<std::size_t> ends;
    for (std::size_t i = 1; i < text.size(); ++i) {
        if ((static_cast<unsigned char>(text[i]) & 0xC0) != 0x80) {
            ends.push_back(i);
        }
    }
    ends.push_back(text.size());
    return ends;
}

/// Width in pixels `text` is drawn with, or nullopt if it cannot be measured.
std::optional<int> text_width(const std::string& text, const std::string& font) {
    const OIIO::ROI size = OIIO::ImageBufAlgo::text_size(text, kMontageFontSize, font);
    if (!size.defined()) {
        return std::nullopt;
    }
    return size.width();
}

/// `text` if it fits in `max_width` pixels; otherwise its longest code-point prefix that fits
/// with `ellipsis` appended; empty if not even the ellipsis fits. OpenImageIO places glyphs by
/// their advances alone (no kerning), so a longer prefix pushes the ellipsis further right and
/// the width never shrinks: a binary search finds the cut.
std::string fitted_label(const std::string& text, const std::string& font, int max_width,
                         const std::string& ellipsis) {
    const auto fits = [&](const std::string& candidate) {
        const std::optional<int> w = text_width(candidate, font);
        return w && *w <= max_width;
    };
    if (fits(text)) {
        return text;
    }
    const std::vector<std::size_t> ends = code_point_ends(text);
    std::size_t lo = 0;  // ends[0..lo) fit
    std::size_t hi = ends.size();
    while (lo < hi) {
        const std::size_t mid = (lo + hi) / 2;
        if (fits(text.substr(0, ends[mid]) + ellipsis)) {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    if (lo == 0) {
        return fits(ellipsis) ? ellipsis : std::string();
    }
    std::string prefix = text.substr(0, ends[lo - 1]);
    prefix.erase(prefix.find_last_not_of(' ') + 1);
    return prefix + ellipsis;
}

/// Draws `text` centred in the label strip whose top-left is (x, y) and which is `width` pixels
/// wide. The text is rendered into a buffer of exactly the strip's size, so no glyph can reach
/// a neighbouring cell whatever the font measures. `baseline` is measured from the strip's top.
/// Returns false when OpenImageIO could not draw it.
bool draw_label(Image& montage, int x, int y, int width, int baseline, const std::string& text,
                const std::string& font) {
    const int height = kMontageLabelHeight;
    std::vector<float> strip(static_cast<std::size_t>(width) * height * 3, kMontageBackground);
    OIIO::ImageBuf buffer(OIIO::ImageSpec(width, height, 3, OIIO::TypeDesc::FLOAT), strip.data());
    const float colour[3] = {kMontageTextColour, kMontageTextColour, kMontageTextColour};
    if (!OIIO::ImageBufAlgo::render_text(buffer, width / 2, baseline, text, kMontageFontSize, font,
                                         colour, OIIO::ImageBufAlgo::TextAlignX::Center,
                                         OIIO::ImageBufAlgo::TextAlignY::Baseline)) {
        // Consumed so OpenImageIO does not complain about an unread error when `buffer` dies.
        buffer.geterror();
        return false;
    }
    for (int j = 0; j < height; ++j) {
        for (int i = 0; i < width; ++i) {
            const float* p = &strip[(static_cast<std::size_t>(j) * width + i) * 3];
            montage.set(x + i, y + j, Rgb(p[0], p[1], p[2]));
        }
    }
    return true;
}

/// Baseline, from the strip's top, that centres the font's usual ascent and descent (measured
/// on "Hg") in the strip, the same for every label so that a row's labels line up.
int label_baseline(const std::string& font) {
    const OIIO::ROI extent = OIIO::ImageBufAlgo::text_size("Hg", kMontageFontSize, font);
    if (!extent.defined()) {
        return (kMontageLabelHeight + kMontageFontSize) / 2;
    }
    // ybegin is negative: the ascent above the baseline.
    return (kMontageLabelHeight - extent.height()) / 2 - extent.ybegin;
}

}  // namespace

Image make_montage(const std::vector<MontageCell>& cells, int columns,
                   const MontageOptions& options) {
    if (columns < 1) {
        throw Error(fmt::format("make_montage: columns must be at least 1, got {}", columns));
    }
    if (options.cell_width < kMinCellWidth) {
        throw Error(fmt::format("make_montage: cell_width must be at least {} px, got {}",
                                kMinCellWidth, options.cell_width));
    }
    if (cells.empty()) {
        throw Error("make_montage: no cells to lay out (the cell list is empty)");
    }
    const int cell_width = options.cell_width;
    const Layout layout = compute_layout(cells, columns, cell_width);

    Image montage(layout.width, layout.height, Rgb::Constant(kMontageBackground));
    for (std::size_t i = 0; i < cells.size(); ++i) {
        const Image cell = scaled(cells[i].image, cell_width, layout.image_heights[i]);
        for (int y = 0; y < cell.height(); ++y) {
            for (int x = 0; x < cell.width(); ++x) {
                montage.set(layout.x[i] + x, layout.y[i] + y, cell.at(x, y));
            }
        }
    }

    const bool any_label = std::any_of(cells.begin(), cells.end(), [](const MontageCell& c) {
        return !drawable_label(c.label, Glyphs::Unicode).empty();
    });
    if (!any_label) {
        return montage;
    }
    const std::optional<std::string> font = usable_font(options.fonts);
    if (!font) {
        if (options.warn) {
            options.warn(
                fmt::format("montage labels not drawn: none of the fonts could be loaded ({})",
                            fmt::join(options.fonts, ", ")));
        }
        return montage;
    }
    const Glyphs glyphs = oiio_decodes_utf8() ? Glyphs::Unicode : Glyphs::Ascii;
    const std::string ellipsis = glyphs == Glyphs::Unicode ? kEllipsis : kAsciiEllipsis;
    const int baseline = label_baseline(*font);
    const int max_text_width = cell_width - 2 * kLabelPadding;
    std::vector<std::size_t> failed;
    for (std::size_t i = 0; i < cells.size(); ++i) {
        const std::string text =
            fitted_label(drawable_label(cells[i].label, glyphs), *font, max_text_width, ellipsis);
        if (!text.empty() && !draw_label(montage, layout.x[i], layout.label_y[i], cell_width,
                                         baseline, text, *font)) {
            failed.push_back(i);
        }
    }
    if (!failed.empty() && options.warn) {
        options.warn(fmt::format("montage labels of cells {} could not be drawn with font {}",
                                 fmt::join(failed, ", "), *font));
    }
    return montage;
}

Image make_montage(const std::vector<MontageCell>& cells, int columns, int cell_width) {
    MontageOptions options;
    options.cell_width = cell_width;
    return make_montage(cells, columns, options);
}

}  // namespace mrt
