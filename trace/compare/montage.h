#pragma once
// A labelled montage of images: method renderings and their false-colour error images side by
// side (mrt-compare), each cell with its name underneath. Text is drawn with OpenImageIO, which
// stays behind montage.cpp like the rest of the image code.

#include "common/image/image.h"

#include <functional>
#include <string>
#include <vector>

namespace mrt {

/// One image of a montage and the text under it.
struct MontageCell {
    /// Linear RGB; cells may have different sizes. Must not be empty.
    Image image;
    /// One line of UTF-8 drawn centred under the cell; may be empty. Control characters
    /// (newlines, tabs) are shown as spaces, and a label wider than the cell is cut with an
    /// ellipsis (…). OpenImageIO 2.4 (Debian 12) decodes UTF-8 wrongly, so with it labels are
    /// drawn in ASCII: "..." for the ellipsis, "x" for "×", "->" for "→", "-" for dashes,
    /// "+/-" for "±", and "?" for any other non-ASCII character.
    std::string label;
};

/// Space between cells, and between the cells and the montage's border, in pixels.
inline constexpr int kMontageMargin = 8;
/// Height of the label strip under every cell, in pixels (present even when a label is empty,
/// so that rows line up whatever the labels are).
inline constexpr int kMontageLabelHeight = 24;
/// Nominal height of the label text, in pixels.
inline constexpr int kMontageFontSize = 14;
/// Background of the montage (margins, label strips, unused cells): a dark grey, linear RGB
/// (about 48/255 once sRGB encoded).
inline constexpr float kMontageBackground = 0.03f;
/// Colour of the label text, linear RGB (a light grey, about 231/255 sRGB encoded).
inline constexpr float kMontageTextColour = 0.8f;
/// The DejaVu Sans file installed by fonts-dejavu-core (see scripts/setup).
inline constexpr const char* kDejaVuSansPath = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

/// How a montage is drawn beyond its cells and column count.
struct MontageOptions {
    /// Width every cell image is scaled to, in pixels (at least 16).
    int cell_width = 256;
    /// Fonts for the labels, tried in order: a font file path, or a name OpenImageIO searches for
    /// in its font directories (/usr/share/fonts among them). The first that loads is used.
    std::vector<std::string> fonts = {kDejaVuSansPath, "DejaVuSans"};
    /// Receives a warning when labels cannot be drawn (no usable font); default prints nothing.
    std::function<void(const std::string&)> warn;
};

/// Lays out `cells` row-major in min(`columns`, cells.size()) columns. Every cell image is scaled
/// to `cell_width` pixels wide keeping its aspect, to a height of
///     h = max(1, round(cell_width · image.height / image.width)),
/// box-filtered along an axis that shrinks and nearest-neighbour along one that grows (so
/// upscaled pixels stay sharp). A row is as tall as its tallest image plus the label strip;
/// images are drawn at the top-left of their slot, labels in a strip right under the row's
/// tallest image, so that a row's labels share a baseline. With C columns and rows r:
///     width  = C · cell_width + (C + 1) · kMontageMargin
///     height = Σ_r (max h in row r + kMontageLabelHeight) + (rows + 1) · kMontageMargin
/// The cell in column c, row r has its left edge at x = kMontageMargin + c · (cell_width +
/// kMontageMargin). Everything not covered by an image or text is kMontageBackground.
///
/// Text never leaves the cell's own column: it is drawn into a buffer exactly as wide as the
/// cell. If no font in `options.fonts` can be loaded the montage is still laid out the same
/// way, with empty label strips, and `options.warn` is told once.
///
/// Returns a linear RGB image for write_image. Throws mrt::Error when `columns` < 1,
/// `cell_width` < 16, `cells` is empty, a cell image is empty, or the montage would be too large
/// for an Image.
Image make_montage(const std::vector<MontageCell>& cells, int columns,
                   const MontageOptions& options);

/// make_montage with default options and the given cell width.
Image make_montage(const std::vector<MontageCell>& cells, int columns, int cell_width = 256);

}  // namespace mrt
