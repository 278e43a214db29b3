#pragma once
// Sub-pixel coverage masks for the cone's A-buffer: the fix Wand & Straßer name for their
// opacity A-buffer's main error (§7: "use subpixel masks for each ray (similar to the original
// A-buffer [Carpenter 1984]) to estimate the mutual visibility of the fragments during
// compositing").
//
// A mask is 64 bits, one per sample position over the cone's cross-section. The positions are
// in the footprint Gaussian's own units (the frame in which the Gaussian is exp(−|y|²)/π, as
// gaussian_triangle_mass and the point weights use it), so the same bit means the same ray of the
// cone at every depth, however the footprint has sheared and stretched by then. Each position
// stands for an equal share, 1/64, of the Gaussian's mass inside the 2 % clip (kPointWeightClip)
// that every weight of the cone is cut at: a mask's popcount / 64 estimates the clipped mass of
// what it covers, so masks of a surface's triangles add up to the weight they would have had.
//
// The positions are a golden-angle spiral in mass: sample i at the radius where the clipped
// mass inside reaches (i + ½)/64 of the whole, at angle i·α. A half-plane's mask then misses its
// Gaussian mass by at most kHalfPlaneMaskError (measured over all directions and offsets by
// tests/trace/cone/coverage_mask_test.cpp), where a regular grid of 8 rings of 8 misses it by
// twice as much along its rows.

#include "common/math/math.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <utility>

namespace mrt {

using CoverageMask = std::uint64_t;

inline constexpr int kCoverageSamples = 64;
inline constexpr CoverageMask kFullCoverage = ~CoverageMask{0};

/// The largest difference between a half-plane's mask area and its clipped Gaussian mass, over
/// every direction and offset (0.045 measured, 2.9 samples' worth).
inline constexpr float kHalfPlaneMaskError = 0.05f;
/// The same for triangles within the clip circle (0.061 measured over 3 000 random ones at four
/// scales, 0.010 on average).
inline constexpr float kTriangleMaskError = 0.08f;

/// The sample positions in structure-of-arrays form, in the Gaussian's units.
struct CoverageSamples {
    alignas(64) std::array<float, kCoverageSamples> x;
    alignas(64) std::array<float, kCoverageSamples> y;
};

/// What the samples of a cone's masks stand for.
enum class SamplePattern : std::uint8_t {
    /// Equal mass of the footprint's clipped Gaussian: the rays of a camera, reflected or
    /// refracted cone (and of a shadow cone toward a point light, its receiver's footprint).
    Gaussian,
    /// Equal area of the uniform disc whose variance the Gaussian has (radius √2 in its units):
    /// a shadow cone toward an elliptical light, whose Gaussian stands for the light's uniform
    /// ellipse (ConeTracer::visibility), so that each sample is a ray to one point of the light
    /// and a penumbra is the share of the light an occluder's masks hide.
    LightDisc,
};

/// The golden-angle spiral of a pattern: sample i at the radius inside which the pattern's
/// measure reaches (i + ½)/64 of the whole, at angle i·α.
const CoverageSamples& coverage_samples(SamplePattern pattern = SamplePattern::Gaussian);

/// The share of the cone's clipped Gaussian that a mask covers.
inline float mask_coverage(CoverageMask mask) {
    return static_cast<float>(std::popcount(mask)) / static_cast<float>(kCoverageSamples);
}

/// The samples strictly to the left of the line through `from` and `to`, directed from `from`
/// (counter-clockwise of it), plus those on the line where the directed edge owns it (the
/// top-left rule of rasterisers): of the two directions of one edge exactly one owns the
/// samples on it, whichever order the two points come in, so triangles that share an edge take
/// each sample once. Nothing for from == to.
CoverageMask edge_mask(const Vec2f& from, const Vec2f& to,
                       SamplePattern pattern = SamplePattern::Gaussian);

/// The samples inside the triangle (a, b, c), of either orientation; nothing for a degenerate
/// triangle or one with a vertex that is not finite.
CoverageMask triangle_mask(const Vec2f& a, const Vec2f& b, const Vec2f& c,
                           SamplePattern pattern = SamplePattern::Gaussian);

/// About round(opacity · 64) samples spread evenly over the cross-section, for a surface that
/// covers only that share of where it lies (a cut-out's filtered opacity): sample i is kept
/// where frac(i·φ + offset) < opacity, φ the golden ratio's fractional part, which the spiral's
/// order (radius growing with i) spreads over every radius. Surfaces of different `offset`
/// (in [0, 1)) keep different samples, so two half-open ones stacked cover three quarters on
/// average rather than the same half twice. All for opacity ≥ 1, none for opacity ≤ 0.
CoverageMask opacity_mask(float opacity, float offset);

/// opacity_mask's offset for a surface (an A-buffer fragment's): different for different
/// surfaces, the same for every intersection of one (Knuth's multiplicative hash).
inline float surface_mask_offset(std::uint32_t surface) {
    return static_cast<float>((surface * 2654435769u) >> 8) * 0x1p-24f;
}

/// The samples inside the ellipse {y : (y − centre)ᵀ·form·(y − centre) ≤ 1}, `form` symmetric
/// positive definite (a surfel's disc as the footprint sees it); nothing where it is not finite.
CoverageMask ellipse_mask(const Vec2f& centre, const Mat2f& form,
                          SamplePattern pattern = SamplePattern::Gaussian);
inline constexpr int kBoxBins = 64;

/// A superset of the samples in a box [x0, x1] × [y0, y1]: those within one bin of it, the
/// samples' extent cut into kBoxBins per axis, from tables of the samples at or beyond each
/// bin's edge (four loads and three ANDs). Cheap enough to ask before making a point's or a
/// triangle's exact mask whether it could add anything to the samples a fragment already
/// holds; asked for every point a masked cone weighs, so `of` is inline and free of branches
/// but for the one that rejects empty and distant boxes.
class BoxMasks {
  public:
    explicit BoxMasks(const CoverageSamples& samples);

    CoverageMask of(float x0, float x1, float y0, float y1) const {
        // Not a number anywhere, an empty box or one beyond the samples: nothing (the exact
        // masks give nothing for the first).
        if (!(x0 <= x1) || !(y0 <= y1) || x1 < -m_extent || x0 > m_extent || y1 < -m_extent ||
            y0 > m_extent) {
            return 0;
        }
        // The four edges' bin coordinates, clamped to [0, kBoxBins] (a box may reach far beyond
        // the samples, where converting would overflow) and truncated, which is the floor of a
        // non-negative number: the edge at or below each; of one at or above it, one more
        // (at most kBoxBins). As one vector, where scalar clamps compile to branches.
        const Eigen::Array4f bins = ((Eigen::Array4f(x0, x1, y0, y1) + m_extent) * m_bins_per_unit)
                                        .max(0.0f)
                                        .min(static_cast<float>(kBoxBins));
        const Eigen::Array4i edge = bins.cast<int>();
        const Eigen::Array4i above_edge = edge.min(kBoxBins - 1) + 1;
        const auto at = [](const std::array<CoverageMask, kBoxBins + 1>& table, int k) {
            return table[static_cast<std::size_t>(k)];
        };
        return at(m_above[0], edge[0]) & at(m_below[0], above_edge[1]) & at(m_above[1], edge[2]) &
               at(m_below[1], above_edge[3]);
    }

  private:
    float m_extent = 0.0f;  ///< The samples' largest coordinate (a hair more).
    float m_bins_per_unit = 0.0f;
    /// m_below[a][k]: the samples whose coordinate a is at most edge k; m_above[a][k] those at
    /// least edge k; edges spaced a bin apart from −m_extent to +m_extent.
    std::array<std::array<CoverageMask, kBoxBins + 1>, 2> m_below{};
    std::array<std::array<CoverageMask, kBoxBins + 1>, 2> m_above{};
};

/// The tables of a pattern's samples, built once.
const BoxMasks& box_masks(SamplePattern pattern);

/// box_masks(pattern).of(x0, x1, y0, y1).
CoverageMask box_mask(float x0, float x1, float y0, float y1,
                      SamplePattern pattern = SamplePattern::Gaussian);

/// ellipse_mask one sample at a time: the reference its SIMD kernel answers as, bit for bit
/// (trace/cone/coverage_mask_simd.h).
CoverageMask ellipse_mask_scalar(const Vec2f& centre, const Mat2f& form,
                                 SamplePattern pattern = SamplePattern::Gaussian);

/// The samples a surface covers, with its holes closed: each sample it misses that is
/// surrounded — at least kClosingNeighbours of its kSampleNeighbours nearest samples covered —
/// taken as covered too (one pass: a hole of two neighbouring samples stays when each has two
/// neighbours missing). Points' discs of the area they stand for leave such holes between
/// them inside a surface (a disc of a lattice cell's area does not reach the cell's corners,
/// and where a surface runs along a layer of voxels two coincident points share its area,
/// each disc the smaller), which would let what lies behind show through; a sample beside an
/// edge or a thin feature has no more than half of its neighbours on the surface and stays
/// uncovered, so closing the holes does not widen silhouettes as larger discs do.
CoverageMask close_holes(CoverageMask mask, SamplePattern pattern = SamplePattern::Gaussian);

inline constexpr int kSampleNeighbours = 6;
inline constexpr int kClosingNeighbours = 5;
static_assert(kSampleNeighbours - kClosingNeighbours == 1, "close_holes tests one missing");

/// A run of the samples: what one level of the hierarchy may cover where the cone blends two
/// (a coarse node's points with weight c, everything below it with 1 − c). The two levels'
/// masks of one surface lie differently over the samples, so their union would cover more
/// than either (the bare plant's coverage with points: 1.50 of the reference); instead the
/// coarse level keeps c of the samples and the finer ones the rest, and the union covers c of
/// the one and 1 − c of the other, as the weights blend them. Ranks follow the spiral from
/// the centre out: the coarse level, whose discs are the larger, takes the inner samples and
/// the finer one the rim (ranks spread over the cross-section, bit-reversed, measured the
/// same on the comparison scenes and a bare plant of 1.11 against 1.10).
struct SampleRange {
    std::uint8_t first = 0;
    std::uint8_t last = kCoverageSamples;

    /// The samples of ranks [first, last).
    CoverageMask mask() const;

    /// The leading part standing for `fraction` of the range (rounded to whole samples,
    /// clamped to [0, 1]) and the rest.
    std::pair<SampleRange, SampleRange> split(float fraction) const;

    bool operator==(const SampleRange&) const = default;
};

}  // namespace mrt
