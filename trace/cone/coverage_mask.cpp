#include "trace/cone/coverage_mask.h"

#include "common/footprint/point_weight.h"
#include "trace/cone/coverage_mask_simd.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>

namespace mrt {

namespace {

CoverageSamples make_coverage_samples(SamplePattern pattern) {
    // Mass inside radius r of exp(−|y|²)/π is 1 − exp(−r²); the clip keeps 1 − kPointWeightClip.
    // The disc of the Gaussian's variance (½ per axis) has radius √2, area inside r ∝ r².
    const double kept = 1.0 - static_cast<double>(kPointWeightClip);
    const double golden_angle = std::numbers::pi * (3.0 - std::sqrt(5.0));
    CoverageSamples samples{};
    for (int i = 0; i < kCoverageSamples; ++i) {
        const double share = (i + 0.5) / kCoverageSamples;
        const double radius = pattern == SamplePattern::Gaussian
                                  ? std::sqrt(-std::log1p(-kept * share))
                                  : std::sqrt(2.0 * share);
        const double angle = golden_angle * i;
        samples.x[static_cast<std::size_t>(i)] = static_cast<float>(radius * std::cos(angle));
        samples.y[static_cast<std::size_t>(i)] = static_cast<float>(radius * std::sin(angle));
    }
    return samples;
}

/// The mask of 64 flags, each 0 or 1: eight at a time, one multiplication gathers a word's eight
/// low bits into its top byte. The loops that fill the flags then vectorise, where setting one
/// bit per iteration would not.
CoverageMask pack(const std::array<std::uint8_t, kCoverageSamples>& flags) {
    CoverageMask mask = 0;
    for (std::size_t group = 0; group < kCoverageSamples / 8; ++group) {
        std::uint64_t word = 0;
        std::memcpy(&word, flags.data() + 8 * group, sizeof word);
        mask |= ((word * 0x0102040810204080ull) >> 56) << (8 * group);
    }
    return mask;
}

/// A directed edge's side test. Its function is evaluated from the lexicographically smaller
/// end whichever way the edge runs, so that the two directions of one edge see exactly opposite
/// values on every sample (negation is exact), and of the two exactly one owns the samples on
/// the line (the top-left rule of rasterisers).
struct Edge {
    float origin_x, origin_y, dx, dy;
    bool owns;

    Edge(const Vec2f& from, const Vec2f& to)
        : dx(to.x() - from.x()),
          dy(to.y() - from.y()),
          owns(dy > 0.0f || (dy == 0.0f && dx > 0.0f)) {
        const bool forward = from.x() < to.x() || (from.x() == to.x() && from.y() < to.y());
        origin_x = forward ? from.x() : to.x();
        origin_y = forward ? from.y() : to.y();
    }

    bool degenerate() const { return dx == 0.0f && dy == 0.0f; }

    /// Whether (x, y) lies to the left of the edge, or on it where the edge owns its line.
    bool holds(float x, float y) const {
        const float value = dx * (y - origin_y) - dy * (x - origin_x);
        return (value > 0.0f) | (owns & (value == 0.0f));
    }
};

/// ranked[k]: the samples of ranks below k, rank(i) being i's six bits reversed.
constexpr std::array<CoverageMask, kCoverageSamples + 1> make_ranked_masks() {
    static_assert(kCoverageSamples == 64, "ranks are six-bit reversals");
    std::array<CoverageMask, kCoverageSamples + 1> ranked{};
    for (int rank = 0; rank < kCoverageSamples; ++rank) {
        int sample = rank;
        ranked[static_cast<std::size_t>(rank + 1)] =
            ranked[static_cast<std::size_t>(rank)] | (CoverageMask{1} << sample);
    }
    return ranked;
}

constexpr std::array<CoverageMask, kCoverageSamples + 1> kRankedMasks = make_ranked_masks();

/// neighbours[i]: sample i's kSampleNeighbours nearest samples.
std::array<CoverageMask, kCoverageSamples> make_neighbours(const CoverageSamples& s) {
    std::array<CoverageMask, kCoverageSamples> neighbours{};
    for (std::size_t i = 0; i < kCoverageSamples; ++i) {
        std::array<std::pair<float, std::size_t>, kCoverageSamples - 1> by_distance;
        std::size_t n = 0;
        for (std::size_t j = 0; j < kCoverageSamples; ++j) {
            if (j != i) {
                const float dx = s.x[j] - s.x[i];
                const float dy = s.y[j] - s.y[i];
                by_distance[n++] = {dx * dx + dy * dy, j};
            }
        }
        std::partial_sort(by_distance.begin(), by_distance.begin() + kSampleNeighbours,
                          by_distance.end());
        for (int k = 0; k < kSampleNeighbours; ++k) {
            neighbours[i] |= CoverageMask{1} << by_distance[static_cast<std::size_t>(k)].second;
        }
    }
    return neighbours;
}

}  // namespace

BoxMasks::BoxMasks(const CoverageSamples& s) {
    for (std::size_t k = 0; k < kCoverageSamples; ++k) {
        m_extent = std::max({m_extent, std::abs(s.x[k]), std::abs(s.y[k])});
    }
    // A sample on the outermost edge stays within the tables' range after rounding.
    m_extent *= 1.0f + 1e-5f;
    const float bin = 2.0f * m_extent / kBoxBins;
    m_bins_per_unit = 1.0f / bin;
    for (std::size_t a = 0; a < 2; ++a) {
        const auto& coordinate = a == 0 ? s.x : s.y;
        for (std::size_t k = 0; k <= kBoxBins; ++k) {
            const float edge = -m_extent + static_cast<float>(k) * bin;
            for (std::size_t i = 0; i < kCoverageSamples; ++i) {
                // A twentieth of a bin's slack either way: the lookups round the box's edges
                // to bin edges in floats, and must not lose a sample to that.
                if (coordinate[i] <= edge + 0.05f * bin) {
                    m_below[a][k] |= CoverageMask{1} << i;
                }
                if (coordinate[i] >= edge - 0.05f * bin) {
                    m_above[a][k] |= CoverageMask{1} << i;
                }
            }
        }
    }
}

const BoxMasks& box_masks(SamplePattern pattern) {
    static const std::array<BoxMasks, 2> tables{
        BoxMasks(coverage_samples(SamplePattern::Gaussian)),
        BoxMasks(coverage_samples(SamplePattern::LightDisc))};
    return tables[static_cast<std::size_t>(pattern)];
}

CoverageMask box_mask(float x0, float x1, float y0, float y1, SamplePattern pattern) {
    return box_masks(pattern).of(x0, x1, y0, y1);
}

CoverageMask close_holes(CoverageMask mask, SamplePattern pattern) {
    static const std::array<std::array<CoverageMask, kCoverageSamples>, 2> patterns{
        make_neighbours(coverage_samples(SamplePattern::Gaussian)),
        make_neighbours(coverage_samples(SamplePattern::LightDisc))};
    const auto& neighbours = patterns[static_cast<std::size_t>(pattern)];
    CoverageMask closed = mask;
    for (CoverageMask missing = ~mask; missing != 0; missing &= missing - 1) {
        const int i = std::countr_zero(missing);
        // At most kSampleNeighbours − kClosingNeighbours = 1 neighbour missing: no popcount,
        // which this build's baseline instruction set lacks.
        const CoverageMask missing_neighbours = neighbours[static_cast<std::size_t>(i)] & ~mask;
        if ((missing_neighbours & (missing_neighbours - 1)) == 0) {
            closed |= CoverageMask{1} << i;
        }
    }
    return closed;
}

CoverageMask SampleRange::mask() const {
    return kRankedMasks[last] & ~kRankedMasks[first];
}

std::pair<SampleRange, SampleRange> SampleRange::split(float fraction) const {
    const float share = std::isfinite(fraction) ? std::clamp(fraction, 0.0f, 1.0f) : 0.0f;
    const auto middle = static_cast<std::uint8_t>(
        first + static_cast<int>(std::lround(share * static_cast<float>(last - first))));
    return {SampleRange{first, middle}, SampleRange{middle, last}};
}

const CoverageSamples& coverage_samples(SamplePattern pattern) {
    static const std::array<CoverageSamples, 2> patterns{
        make_coverage_samples(SamplePattern::Gaussian),
        make_coverage_samples(SamplePattern::LightDisc)};
    return patterns[static_cast<std::size_t>(pattern)];
}

CoverageMask edge_mask(const Vec2f& from, const Vec2f& to, SamplePattern pattern) {
    const Edge edge(from, to);
    if (edge.degenerate()) {
        return 0;
    }
    const CoverageSamples& s = coverage_samples(pattern);
    alignas(64) std::array<std::uint8_t, kCoverageSamples> inside;
    for (std::size_t k = 0; k < kCoverageSamples; ++k) {
        inside[k] = static_cast<std::uint8_t>(edge.holds(s.x[k], s.y[k]));
    }
    return pack(inside);
}

CoverageMask triangle_mask(const Vec2f& a, const Vec2f& b, const Vec2f& c, SamplePattern pattern) {
    if (!a.allFinite() || !b.allFinite() || !c.allFinite()) {
        return 0;
    }
    const double orientation =
        (static_cast<double>(b.x()) - a.x()) * (static_cast<double>(c.y()) - a.y()) -
        (static_cast<double>(b.y()) - a.y()) * (static_cast<double>(c.x()) - a.x());
    if (orientation == 0.0) {
        return 0;
    }
    // Counter-clockwise, so that the inside is to the left of every edge.
    const Vec2f& second = orientation > 0.0 ? b : c;
    const Vec2f& third = orientation > 0.0 ? c : b;
    const Edge e0(a, second);
    const Edge e1(second, third);
    const Edge e2(third, a);
    const CoverageSamples& s = coverage_samples(pattern);
    alignas(64) std::array<std::uint8_t, kCoverageSamples> inside;
    for (std::size_t k = 0; k < kCoverageSamples; ++k) {
        const float x = s.x[k];
        const float y = s.y[k];
        inside[k] = static_cast<std::uint8_t>(e0.holds(x, y) & e1.holds(x, y) & e2.holds(x, y));
    }
    return pack(inside);
}

CoverageMask ellipse_mask(const Vec2f& centre, const Mat2f& form, SamplePattern pattern) {
    if (!centre.allFinite() || !form.allFinite()) {
        return 0;
    }
    return samples_in_ellipse(coverage_samples(pattern), centre.x(), centre.y(), form(0, 0),
                              0.5f * (form(0, 1) + form(1, 0)), form(1, 1));
}

CoverageMask ellipse_mask_scalar(const Vec2f& centre, const Mat2f& form, SamplePattern pattern) {
    if (!centre.allFinite() || !form.allFinite()) {
        return 0;
    }
    const float xx = form(0, 0);
    const float xy = 0.5f * (form(0, 1) + form(1, 0));
    const float yy = form(1, 1);
    const CoverageSamples& s = coverage_samples(pattern);
    alignas(64) std::array<std::uint8_t, kCoverageSamples> inside;
    for (std::size_t k = 0; k < kCoverageSamples; ++k) {
        const float dx = s.x[k] - centre.x();
        const float dy = s.y[k] - centre.y();
        const float q = xx * dx * dx + 2.0f * xy * dx * dy + yy * dy * dy;
        inside[k] = static_cast<std::uint8_t>(q <= 1.0f);
    }
    return pack(inside);
}

CoverageMask opacity_mask(float opacity, float offset) {
    if (!(opacity > 0.0f)) {
        return 0;
    }
    if (opacity >= 1.0f) {
        return kFullCoverage;
    }
    constexpr double kGoldenFraction = 0.6180339887498949;
    CoverageMask mask = 0;
    for (int i = 0; i < kCoverageSamples; ++i) {
        const double position = static_cast<double>(i) * kGoldenFraction + offset;
        if (position - std::floor(position) < static_cast<double>(opacity)) {
            mask |= CoverageMask{1} << i;
        }
    }
    return mask;
}

}  // namespace mrt
