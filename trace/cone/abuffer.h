#pragma once
// The per-ray A-buffer of Wand & Straßer §4.4 (after Zwicker et al.'s surface splatting): the
// cone tracer inserts every point and triangle intersection of one ray cone ("fragments" of
// surface) with its weight (common/footprint/point_weight.h) and a depth tolerance interval; points
// whose intervals overlap are one piece of surface and are averaged, the rest stay separate
// fragments in depth order, and the fragments are alpha-blended front to back with alpha = min(1,
// weight sum) — "any fragment in the interior of any surface has at least a weight of one.
// Therefore, we can interpret weight sums of less than one as alpha values to blend edges."
//
// Hot path: one buffer per ray, fixed capacity (std::array, no allocation), cleared in O(1).
// Invariant: fragments [0, size()) have disjoint closed intervals in increasing depth,
// fragment[i].far < fragment[i + 1].near, so the first fragment whose far end reaches a new
// interval is the only one that can overlap it from the front, and a merge can only ever spill
// into the fragments behind it (the cascade).
//
// With coverage masks (Compositing::Mask, the A-buffer of Carpenter 1984 that the paper's §7
// proposes; trace/cone/coverage_mask.h) each fragment also carries the samples of the cone's
// cross-section that its surface covers, OR'ed over what merges into it, and the composite
// gives each sample to the nearest fragment that covers it: a fragment's share of the cone is
// the weight of the samples it takes, not min(1, weight). Coverage that two fragments share
// then counts once, and coverage that they split adds up.

#include "common/math/math.h"
#include "common/system/check.h"
#include "common/system/enum_names.h"
#include "common/system/fields.h"
#include "trace/cone/coverage_mask.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>
#include <ostream>
#include <span>
#include <type_traits>
#include <utility>

namespace mrt {

/// What the tracer's per-fragment attribute record must provide. A value-initialised `A{}` is
/// the empty sum. The record decides how each field combines, so a field that must not be
/// averaged — the normal gradient (§4.4: "use nearest neighbor sampling for the differential
/// properties") — can keep the contributor of the largest weight by storing that weight beside
/// it and comparing in `add` and `merge`.
///  - `sums.add(point, weight)`: accumulate one intersection's attributes (`point` holds the
///    point's own values, not sums) with its weight, weight > 0 and finite;
///  - `sums.merge(other)`: add another fragment's sums (both built by `add`/`merge`);
///  - `sums.averaged(weight_sum)`: the fragment's record as the shader reads it — averaged
///    fields divided by `weight_sum` (> 0, the sum of the weights passed to `add`), normals
///    renormalised, nearest-neighbour fields as they are.
template <class A>
concept FragmentAttributes = std::default_initializable<A> && std::copyable<A> &&
    requires(A& sums, const A& other, float weight) {
    { sums.add(other, weight) } -> std::same_as<void>;
    { sums.merge(other) } -> std::same_as<void>;
    { std::as_const(sums).averaged(weight) } -> std::convertible_to<A>;
};

/// Below this transmittance a ray counts as opaque for early termination: what lies behind can
/// change the pixel by at most this fraction of its radiance (1e-4: under half an 8-bit step of
/// a background up to 20× brighter than white).
inline constexpr float kOpaqueTransmittance = 1e-4f;

/// An intersection's coverage mask for ABuffer::insert: the samples themselves, or a callable
/// that, given the samples of the fragment the intersection joins, returns at least those of
/// its samples the fragment lacks (any of the ones it holds may be left out), so that a mask
/// that cannot add anything need not be made exactly. Called at most once per insertion.
template <class M>
concept MaskSource = std::is_invocable_r_v<CoverageMask, const M&, CoverageMask> ||
    std::convertible_to<M, CoverageMask>;

/// The samples of `mask` that matter to a fragment holding `held`, or more.
template <MaskSource M>
CoverageMask samples_beyond(const M& mask, CoverageMask held) {
    if constexpr (std::is_invocable_r_v<CoverageMask, const M&, CoverageMask>) {
        return mask(held);
    } else {
        return static_cast<CoverageMask>(mask);
    }
}

/// One piece of surface along a ray: the union of the depth tolerance intervals of the
/// intersections merged into it, and their weight-summed attributes.
template <class A>
struct Fragment {
    float near = 0.0f;  ///< Front of the depth interval, ray parameter t (world units along d).
    float far = 0.0f;   ///< Back of the depth interval, ray parameter t; near ≤ far.
    /// Σ w_i of the merged intersections (dimensionless point weights).
    float weight = 0.0f;
    /// Σ w_i·o_i, o_i the opacity of intersection i (a cut-out's, filtered over the footprint;
    /// 1 for a solid surface): what of the weight stands.
    float opaque_weight = 0.0f;
    /// Σ w_i·t_i, ray parameter × weight: the weighted mean depth is weighted_depth / weight.
    float weighted_depth = 0.0f;
    A sums{};  ///< Σ w_i·attributes_i, as accumulated by A::add and A::merge.
    /// The samples of the cone's cross-section the merged intersections cover (mask
    /// compositing; 0 where the buffer composites by alpha).
    CoverageMask mask = 0;
    /// Which surface the intersections belong to: the mesh object whose tree they came from,
    /// or kAnySurface (a group's points, or with alpha compositing intersections of several
    /// surfaces merged). With masks only intersections of one surface merge; a cone leaving
    /// the fragment knows which surface it leaves (ConeTraversal::trace).
    std::uint32_t surface = 0;

    /// The weighted mean depth of the intersections, ray parameter t (where to shade).
    float depth() const { return weighted_depth / weight; }
    /// The samples of `samples` (its mask, or that mask with its holes closed) the fragment
    /// stands on: all of them for a solid surface; for a cut-out, a share of them as large as
    /// its intersections' weighted mean opacity, spread over the cross-section (opacity_mask).
    /// The fragment's mean, not each intersection's: overlapping discs of points of different
    /// opacity would otherwise take the largest where they overlap.
    CoverageMask standing(CoverageMask samples) const {
        if (opaque_weight == weight) {
            return samples;
        }
        return samples & opacity_mask(opaque_weight / weight, surface_mask_offset(surface));
    }
    /// The fragment's opacity (§4.4): its weight sum, at most one, times the weighted mean
    /// opacity of its intersections. The weight says how much of the footprint the surface
    /// covers (saturating, since the points' weights are lifted by κ to cover interiors); a
    /// cut-out then lets through what its opacity does not stop, which a product of weight and
    /// opacity would overstate by up to κ.
    float alpha() const {
        const float a = std::min(1.0f, weight);
        return opaque_weight == weight ? a : a * (opaque_weight / weight);
    }
};

template <class A>
std::ostream& operator<<(std::ostream& os, const Fragment<A>& f) {
    os << "Fragment{[" << f.near << ", " << f.far << "], weight " << f.weight << ", depth "
       << f.depth();
    if constexpr (requires(std::ostream & o, const A& a) { o << a; }) {
        os << ", sums " << f.sums;
    }
    return os << '}';
}

/// What an A-buffer did with its insertions, for the tracer's --stats (add up over rays with
/// +=). Counts are of insert() calls unless they say fragments.
struct ABufferStats {
    std::uint64_t inserted = 0;  ///< Accepted insertions (valid weight, depth and tolerance).
    std::uint64_t ignored = 0;  ///< Rejected: weight ≤ 0 or not finite, t or tolerance not finite.
    std::uint64_t merged = 0;   ///< Insertions whose interval overlapped a fragment.
    /// Fragments absorbed by a neighbour whose united interval grew into theirs.
    std::uint64_t cascaded = 0;
    /// Buffer full: merges of surfaces that did not overlap (the closest pair in depth).
    std::uint64_t forced_merges = 0;
    /// Buffer full: insertions dropped because they lay behind the opaque depth.
    std::uint64_t dropped_insertions = 0;
    /// Buffer full: fragments behind the opaque depth evicted to make room.
    std::uint64_t evicted_fragments = 0;
    double dropped_weight = 0.0;  ///< Σ weight of the dropped insertions and evicted fragments.

    /// Surface lost to a full buffer: insertions dropped and fragments evicted.
    std::uint64_t dropped() const { return dropped_insertions + evicted_fragments; }

    /// Named as --stats writes them (inside each traversal kind's record).
    static constexpr auto fields = std::tuple{
        Field{"fragments_inserted", &ABufferStats::inserted},
        Field{"fragments_ignored", &ABufferStats::ignored},
        Field{"fragments_merged", &ABufferStats::merged},
        Field{"fragments_cascaded", &ABufferStats::cascaded},
        Field{"abuffer_forced_merges", &ABufferStats::forced_merges},
        Field{"abuffer_dropped_insertions", &ABufferStats::dropped_insertions},
        Field{"abuffer_evicted_fragments", &ABufferStats::evicted_fragments},
        Field{"abuffer_dropped_weight", &ABufferStats::dropped_weight},
        Field{"abuffer_dropped", &ABufferStats::dropped},
    };
    ABufferStats& operator+=(const ABufferStats& o) { return add_fields(*this, o); }
};

inline std::ostream& operator<<(std::ostream& os, const ABufferStats& s) {
    return print_fields(os, "ABufferStats", s);
}

/// The surface of an intersection that may stand for any surface: a group's points, which
/// approximate every instance below them (the surfaces of many objects at once). It merges
/// with whatever it overlaps, as every intersection does with alpha compositing.
inline constexpr std::uint32_t kAnySurface = std::numeric_limits<std::uint32_t>::max();

/// Whether intersections of surfaces a and b may merge (may be one surface).
inline bool same_surface(std::uint32_t a, std::uint32_t b) {
    return a == b || a == kAnySurface || b == kAnySurface;
}

/// The surface of a fragment that intersections of surfaces a and b were merged into where
/// surfaces do not keep apart (alpha compositing, a full buffer's forced merges): one of them
/// only where both are the same.
inline std::uint32_t merged_surface(std::uint32_t a, std::uint32_t b) {
    return a == b ? a : kAnySurface;
}

/// How an A-buffer turns its fragments into a pixel.
enum class Compositing : std::uint8_t {
    Alpha,  ///< §4.4: each fragment's alpha is min(1, weight sum), blended front to back.
    Mask,   ///< Each sample of the fragments' coverage masks is taken by the nearest fragment.
};

inline constexpr EnumNames<Compositing, 2> kCompositingNames{{{
    {Compositing::Alpha, "alpha"},
    {Compositing::Mask, "mask"},
}}};

/// The outcome of front-to-back blending: Σ_i T_i·α_i·c_i and the transmittance left after the
/// last fragment, T = Π_i (1 − α_i), for the background or the ray's continuation.
struct CompositeResult {
    Rgb radiance = Rgb::Zero();  ///< Blended radiance, the units shade() returns.
    float transmittance = 1.0f;  ///< Fraction of what lies behind the fragments that shows, [0, 1].
    /// With masks, the samples the fragments take (transmittance is the share of the rest).
    CoverageMask covered = 0;
};

inline std::ostream& operator<<(std::ostream& os, const CompositeResult& r) {
    return os << "CompositeResult{radiance (" << r.radiance[0] << ", " << r.radiance[1] << ", "
              << r.radiance[2] << "), transmittance " << r.transmittance << '}';
}

/// The A-buffer of one ray: at most `Capacity` fragments sorted by depth. Copying, clearing
/// and inserting never allocate; the buffer is trivially copyable when A is.
///
/// Overflow (a new, non-overlapping intersection when all Capacity fragments are in use), in
/// order of preference — the least wrong change to the composite:
///  1. the new interval starts behind opaque_depth(): it is dropped (it could show through at
///     most kOpaqueTransmittance);
///  2. the last fragment starts behind opaque_depth(): it is evicted, and the new one inserted;
///  3. otherwise the two depth-closest neighbours among the fragments and the new interval
///     (smallest gap between intervals) merge, as if their tolerance had been larger: the
///     error is a wrong depth order of nearby surfaces, never a lost one.
/// Each case is counted in stats().
///
/// 32 fragments: with masks a fragment holds one surface, and a cone over the field's plants
/// meets more surfaces than 16 before its masks fill. At 16 its primary cones merged by force
/// 3.5 times each and its secondary ones 10 times (glass merged with the ground behind it); 32
/// halves that, takes the field's RMSE at 640×480 from 0.0685 to 0.0666 (display 0.0524 →
/// 0.0518) at the same time, and costs 2.4 kB more per cone on the stack; 64 gained less again.
template <FragmentAttributes A, int Capacity = 32>
class ABuffer {
    static_assert(Capacity >= 1, "an A-buffer holds at least one fragment");

  public:
    using Attributes = A;
    using FragmentType = Fragment<A>;
    static constexpr int kCapacity = Capacity;

    /// Empties the buffer and its statistics for the next ray (O(1): the storage stays). The
    /// compositing mode stays.
    void clear() {
        m_count = 0;
        m_stats = {};
        m_opaque_known = false;
    }

    /// How opaque_depth() and composite() read the fragments, and what the masks' samples
    /// stand for (the traversal makes the masks in that pattern); set on an empty buffer.
    void set_compositing(Compositing compositing, SamplePattern pattern = SamplePattern::Gaussian) {
        MRT_DCHECK(m_count == 0);
        m_compositing = compositing;
        m_pattern = pattern;
        m_opaque_known = false;
    }

    SamplePattern sample_pattern() const { return m_pattern; }

    /// Inserts an intersection at ray parameter t with depth tolerance interval
    /// [t − tolerance, t + tolerance] (tolerance ≥ 0 in units of t, proportional to the node's
    /// point spacing, §4.4), weight `weight` and the intersection's own attributes. An interval
    /// overlapping a fragment's (closed intervals: touching counts) merges into it, the united
    /// interval absorbing the fragments behind it that it now reaches; otherwise the
    /// intersection becomes a new fragment in depth order. Weights that are not positive and
    /// finite, and t or tolerance that are not finite, are ignored (counted); a negative
    /// tolerance counts as 0.
    ///
    /// `attributes` is an A, or anything A::add accepts: a contribution that computes an
    /// expensive attribute only when the fragment keeps it (the shape operator of a cone's
    /// largest-weight contributor, trace/cone/cone_surface.h). `mask` is the samples the
    /// intersection covers, for mask compositing, or a MaskSource that makes them only where a
    /// fragment keeps them.
    ///
    /// With masks, `surface` tells surfaces apart (the object an intersection came from): only
    /// intersections of one surface merge, so that two surfaces closer than the tolerance — a
    /// sheet of paper on a desk — stay two fragments and the nearer takes its samples first,
    /// instead of one fragment of their averaged colour. Fragments of different surfaces may
    /// then overlap in depth; they are kept in order of their intervals' fronts. With alpha
    /// compositing surfaces merge as before, and a fragment records the one surface its
    /// intersections came from, or kAnySurface where they came from several.
    template <class Contribution = A, MaskSource Mask = CoverageMask>
    requires requires(A& sums, const Contribution& c, float w) { sums.add(c, w); }
    void insert(float t, float tolerance, float weight, const Contribution& attributes,
                const Mask& mask = 0, std::uint32_t surface = 0, float opacity = 1.0f) {
        if (insert_fragment(t, tolerance, weight, attributes, mask, surface,
                            std::clamp(opacity, 0.0f, 1.0f))) {
            m_opaque_known = false;
        }
    }

    /// The depth beyond which nothing can show any more: walking front to back with
    /// α_i = min(1, weight_i), the far end of the first fragment after which the transmittance
    /// Π(1 − α_j) is at most kOpaqueTransmittance; +infinity while it is not.
    ///
    /// Contract for early termination: an intersection whose interval starts strictly behind
    /// it (t − tolerance > opaque_depth()) changes the composite by at most
    /// kOpaqueTransmittance × its radiance and may be skipped — unless a later insertion
    /// extends the opaque fragment's interval to reach it (a merge at the far end can move
    /// opaque_depth() back), in which case skipping loses its contribution to that fragment's
    /// average. Anything starting at or before it (in particular what overlaps the opaque
    /// fragment and would merge into it) must still be inserted. Insertions in front can only
    /// move it forward. O(size()).
    ///
    /// With masks: the far end of the fragment whose mask (its holes closed, close_holes)
    /// completes the union of the masks in front of it and its own.
    float opaque_depth() const {
        // Asked at every node a cone visits, far more often than anything is inserted.
        if (!m_opaque_known) {
            m_opaque = find_opaque_depth();
            m_opaque_known = true;
        }
        return m_opaque;
    }

    /// Front-to-back alpha blending (§4.4): result Σ_i T_i·α_i·c_i with T_0 = 1,
    /// T_{i+1} = T_i·(1 − α_i), α_i = min(1, weight_i), stopping once T is 0. The colour c_i is
    /// `shade(averaged, fragment)`, called front to back, where `averaged` is
    /// fragment.sums.averaged(fragment.weight) — the weighted mean the shader needs — and
    /// `fragment` gives the weight, the interval and the mean depth (where to shade).
    /// Fragments behind an exactly opaque one are not shaded.
    ///
    /// With masks: Σ_i s_i·c_i where s_i is the share of the samples fragment i covers (its
    /// mask with its holes closed, close_holes) that no fragment in front of it does, and T the
    /// share no fragment covers; fragments that take no sample are not shaded.
    ///
    /// A shade that also takes a float is given the fragment's share of the cone besides: α_i,
    /// or s_i with masks (what a cone continuing from the fragment stands for).
    template <class Shade>
    requires std::convertible_to<std::invoke_result_t<Shade&, const A&, const FragmentType&>,
                                 Rgb> ||
        std::convertible_to<std::invoke_result_t<Shade&, const A&, const FragmentType&, float>, Rgb>
            CompositeResult composite(Shade&& shade)
    const {
        const auto colour_of = [&](const FragmentType& f, float share) -> Rgb {
            const A averaged = f.sums.averaged(f.weight);
            if constexpr (std::is_invocable_v<Shade&, const A&, const FragmentType&, float>) {
                return shade(averaged, f, share);
            } else {
                return shade(averaged, f);
            }
        };
        MRT_DCHECK(ordered());
        CompositeResult result;
        if (m_compositing == Compositing::Mask) {
            // Nearest first by mean depth: of two overlapping surfaces the one in front.
            std::array<int, Capacity> order;
            for (int i = 0; i < m_count; ++i) {
                int j = i;
                for (; j > 0 && m_fragments[order[j - 1]].depth() > m_fragments[i].depth(); --j) {
                    order[j] = order[j - 1];
                }
                order[j] = i;
            }
            CoverageMask taken = 0;
            for (int k = 0; k < m_count && taken != kFullCoverage; ++k) {
                const FragmentType& f = m_fragments[order[k]];
                const CoverageMask own = f.standing(close_holes(f.mask, m_pattern)) & ~taken;
                if (own == 0) {
                    continue;
                }
                taken |= own;
                const float share = mask_coverage(own);
                result.radiance += share * colour_of(f, share);
            }
            result.transmittance = 1.0f - mask_coverage(taken);
            result.covered = taken;
            return result;
        }
        for (int i = 0; i < m_count && result.transmittance > 0.0f; ++i) {
            const FragmentType& f = m_fragments[i];
            const float alpha = f.alpha();
            const Rgb colour = colour_of(f, alpha);
            result.radiance += (result.transmittance * alpha) * colour;
            result.transmittance *= 1.0f - alpha;
        }
        return result;
    }

    int size() const { return m_count; }
    bool empty() const { return m_count == 0; }
    bool full() const { return m_count == Capacity; }
    /// The fragments, front to back.
    std::span<const FragmentType> fragments() const {
        return std::span<const FragmentType>(m_fragments.data(), static_cast<std::size_t>(m_count));
    }
    const FragmentType& operator[](int i) const { return m_fragments[i]; }
    /// What the insertions since the last clear() did.
    const ABufferStats& stats() const { return m_stats; }

  private:
    /// Returns whether the insertion may have moved opaque_depth(): with masks only a fragment's
    /// interval, its samples or the fragments themselves decide it, and most insertions merge
    /// into a fragment that already spans their interval and holds their samples.
    template <class Contribution, class Mask>
    bool insert_fragment(float t, float tolerance, float weight, const Contribution& attributes,
                         const Mask& mask_source, std::uint32_t surface, float opacity) {
        MRT_DCHECK(ordered());
        if (!(weight > 0.0f) || !std::isfinite(weight) || !std::isfinite(t) ||
            !std::isfinite(tolerance)) {
            ++m_stats.ignored;
            return false;
        }
        ++m_stats.inserted;
        tolerance = std::max(tolerance, 0.0f);
        const float lo = t - tolerance;
        const float hi = t + tolerance;
        if (m_compositing == Compositing::Mask) {
            return insert_surface(t, lo, hi, weight, attributes, mask_source, surface, opacity);
        }
        const CoverageMask mask = samples_beyond(mask_source, 0);
        // The first fragment reaching lo: the fragments before it end before the new interval.
        int i = first_reaching(lo);
        if (i < m_count && m_fragments[i].near <= hi) {
            ++m_stats.merged;
            FragmentType& f = m_fragments[i];
            accumulate(f, t, weight, opacity, attributes, mask);
            f.near = std::min(f.near, lo);
            f.far = std::max(f.far, hi);
            f.surface = merged_surface(f.surface, surface);
            cascade(i);
            return true;
        }
        if (m_count == Capacity &&
            !make_room(i, lo, hi, t, weight, opacity, attributes, mask, surface)) {
            return true;
        }
        start_fragment(i, t, lo, hi, weight, opacity, attributes, mask, surface);
        return true;
    }

    /// opaque_depth(), computed.
    float find_opaque_depth() const {
        if (m_compositing == Compositing::Mask) {
            CoverageMask covered = 0;
            // Fragments of different surfaces overlap: whatever starts behind the far end of
            // every fragment up to the one completing the union lies behind all of them.
            float far = -std::numeric_limits<float>::infinity();
            for (int i = 0; i < m_count; ++i) {
                const CoverageMask mask = m_fragments[i].mask;
                far = std::max(far, m_fragments[i].far);
                // Closing holes cannot complete a union that misses more than a sample's
                // neighbourhood's worth: skip it there (it runs after most insertions). A
                // cut-out's own holes are thinned after its geometry's are closed.
                covered |= m_fragments[i].standing(
                    std::popcount(covered | mask) + kSampleNeighbours >= kCoverageSamples
                        ? close_holes(mask, m_pattern)
                        : mask);
                if (covered == kFullCoverage) {
                    return far;
                }
            }
            return std::numeric_limits<float>::infinity();
        }
        float transmittance = 1.0f;
        for (int i = 0; i < m_count; ++i) {
            transmittance *= 1.0f - m_fragments[i].alpha();
            if (transmittance <= kOpaqueTransmittance) {
                return m_fragments[i].far;
            }
        }
        return std::numeric_limits<float>::infinity();
    }

    /// The invariant every operation keeps (and first_reaching relies on): the fragments in depth
    /// order, each interval ending strictly before the next begins (touching ones are merged).
    bool ordered() const {
        if (m_compositing == Compositing::Mask) {
            for (int i = 0; i < m_count; ++i) {
                if (!(m_fragments[i].near <= m_fragments[i].far) ||
                    (i > 0 && !(m_fragments[i - 1].near <= m_fragments[i].near))) {
                    return false;
                }
                for (int j = 0; j < i; ++j) {
                    if (same_surface(m_fragments[j].surface, m_fragments[i].surface) &&
                        overlaps(m_fragments[j], m_fragments[i].near, m_fragments[i].far)) {
                        return false;
                    }
                }
            }
            return m_count >= 0 && m_count <= Capacity;
        }
        for (int i = 0; i < m_count; ++i) {
            if (!(m_fragments[i].near <= m_fragments[i].far) ||
                (i > 0 && !(m_fragments[i - 1].far < m_fragments[i].near))) {
                return false;
            }
        }
        return m_count >= 0 && m_count <= Capacity;
    }

    static bool overlaps(const FragmentType& f, float lo, float hi) {
        return f.near <= hi && lo <= f.far;
    }

    /// insert() with masks: merges into the fragment of the same surface that the interval
    /// reaches (absorbing the surface's fragments the united interval then reaches), else a
    /// new fragment in order of fronts; a full buffer drops or evicts behind the opaque depth
    /// as with alpha, or else merges the intersection into the fragment nearest in depth,
    /// whatever its surface (its coverage is kept).
    template <class Contribution, class Mask>
    bool insert_surface(float t, float lo, float hi, float weight, const Contribution& attributes,
                        const Mask& mask_source, std::uint32_t surface, float opacity) {
        int i = 0;
        while (i < m_count && !(same_surface(m_fragments[i].surface, surface) &&
                                overlaps(m_fragments[i], lo, hi))) {
            ++i;
        }
        if (i == m_count && m_count == Capacity) {
            if (dropped_or_evicted(lo, weight)) {
                if (m_count == Capacity) {
                    return false;  // dropped
                }
            } else {
                ++m_stats.forced_merges;
                float nearest = std::numeric_limits<float>::infinity();
                for (int j = 0; j < m_count; ++j) {
                    const float gap = std::max(m_fragments[j].near - hi, lo - m_fragments[j].far);
                    if (gap < nearest) {
                        nearest = gap;
                        i = j;
                    }
                }
            }
        }
        if (i < m_count) {
            FragmentType& f = m_fragments[i];
            if (same_surface(f.surface, surface)) {
                ++m_stats.merged;
                // A group's points that merged with one surface's stand for that surface.
                f.surface = f.surface == kAnySurface ? surface : f.surface;
            }
            const CoverageMask before = f.mask;
            accumulate(f, t, weight, opacity, attributes, samples_beyond(mask_source, before));
            if (lo >= f.near && hi <= f.far) {
                // Within the fragment's interval: it reaches no fragment it did not reach
                // before (none of its surface, by the invariant) and keeps its place.
                // A cut-out's intersection lowers the fragment's opacity, and so its samples.
                return f.mask != before || opacity < 1.0f;
            }
            f.near = std::min(f.near, lo);
            f.far = std::max(f.far, hi);
            // The surface's fragments the united interval reaches, until it reaches no more
            // (each absorbed one can widen it).
            for (bool absorbed = true; absorbed;) {
                absorbed = false;
                for (int j = m_count - 1; j >= 0; --j) {
                    FragmentType& into = m_fragments[i];
                    if (j == i || !same_surface(m_fragments[j].surface, into.surface) ||
                        !overlaps(m_fragments[j], into.near, into.far)) {
                        continue;
                    }
                    if (into.surface == kAnySurface) {
                        into.surface = m_fragments[j].surface;
                    }
                    absorb(into, m_fragments[j]);
                    erase(j, 1);
                    ++m_stats.cascaded;
                    absorbed = true;
                    if (j < i) {
                        --i;
                    }
                }
            }
            // Its front may have moved forward past others'.
            for (; i > 0 && m_fragments[i - 1].near > m_fragments[i].near; --i) {
                std::swap(m_fragments[i - 1], m_fragments[i]);
            }
            return true;
        }
        int slot = 0;
        while (slot < m_count && m_fragments[slot].near <= lo) {
            ++slot;
        }
        start_fragment(slot, t, lo, hi, weight, opacity, attributes, samples_beyond(mask_source, 0),
                       surface);
        return true;
    }

    /// A new fragment at index i (size() < Capacity) of the one intersection.
    template <class Contribution>
    void start_fragment(int i, float t, float lo, float hi, float weight, float opacity,
                        const Contribution& attributes, CoverageMask mask, std::uint32_t surface) {
        FragmentType& f = open_slot(i);
        f = FragmentType{};
        f.near = lo;
        f.far = hi;
        f.surface = surface;
        accumulate(f, t, weight, opacity, attributes, mask);
    }

    /// The first two choices of a full buffer (the class comment's overflow policy): drops an
    /// intersection starting at lo behind the opaque depth, or evicts the last fragment where
    /// it starts behind it. Returns true when it did either.
    bool dropped_or_evicted(float lo, float weight) {
        const float opaque = opaque_depth();
        if (lo > opaque) {
            ++m_stats.dropped_insertions;
            m_stats.dropped_weight += weight;
            return true;
        }
        if (m_fragments[m_count - 1].near > opaque) {
            ++m_stats.evicted_fragments;
            m_stats.dropped_weight += m_fragments[m_count - 1].weight;
            --m_count;
            return true;
        }
        return false;
    }

    /// Index of the first fragment with far ≥ lo (size() if none): far increases along the
    /// buffer. A linear scan: at most Capacity short compares, the buffer is small and hot.
    int first_reaching(float lo) const {
        int i = 0;
        while (i < m_count && m_fragments[i].far < lo) {
            ++i;
        }
        return i;
    }

    template <class Contribution>
    static void accumulate(FragmentType& f, float t, float weight, float opacity,
                           const Contribution& attributes, CoverageMask mask) {
        f.sums.add(attributes, weight);
        f.weight += weight;
        f.opaque_weight += weight * opacity;  // exactly `weight` for a solid surface
        f.weighted_depth += weight * t;
        f.mask |= mask;
    }

    /// `into` absorbs `from`'s sums, weights and interval.
    static void absorb(FragmentType& into, const FragmentType& from) {
        into.sums.merge(from.sums);
        into.weight += from.weight;
        into.opaque_weight += from.opaque_weight;
        into.weighted_depth += from.weighted_depth;
        into.mask |= from.mask;
        into.near = std::min(into.near, from.near);
        into.far = std::max(into.far, from.far);
    }

    /// Fragment i's interval grew: absorb the fragments behind it that it now reaches. Nothing
    /// in front can be reached — fragment i was the first to reach the new interval's front.
    void cascade(int i) {
        int j = i + 1;
        while (j < m_count && m_fragments[j].near <= m_fragments[i].far) {
            absorb(m_fragments[i], m_fragments[j]);
            m_fragments[i].surface = merged_surface(m_fragments[i].surface, m_fragments[j].surface);
            ++j;
        }
        const int absorbed = j - (i + 1);
        if (absorbed > 0) {
            m_stats.cascaded += static_cast<std::uint64_t>(absorbed);
            erase(i + 1, absorbed);
        }
    }

    /// Removes fragments [first, first + n), closing the gap.
    void erase(int first, int n) {
        std::move(m_fragments.begin() + first + n, m_fragments.begin() + m_count,
                  m_fragments.begin() + first);
        m_count -= n;
    }

    /// Shifts fragments [i, size()) back by one and returns the freed slot i (size() < Capacity).
    FragmentType& open_slot(int i) {
        std::move_backward(m_fragments.begin() + i, m_fragments.begin() + m_count,
                           m_fragments.begin() + m_count + 1);
        ++m_count;
        return m_fragments[i];
    }

    /// The buffer is full and [lo, hi] overlaps nothing, lying between fragments i − 1 and i:
    /// applies the overflow policy of the class comment. Returns true when a slot is now free
    /// for the new fragment at index i (updated); false when the intersection was dropped or
    /// merged.
    template <class Contribution>
    bool make_room(int& i, float lo, float hi, float t, float weight, float opacity,
                   const Contribution& attributes, CoverageMask mask, std::uint32_t surface) {
        if (dropped_or_evicted(lo, weight)) {
            // Evicted: lo ≤ opaque < its near, the new fragment lies in front of it, i < m_count.
            return m_count < Capacity;
        }
        ++m_stats.forced_merges;
        // The new interval's gaps to its neighbours, and the smallest gap between two
        // neighbouring fragments. A pair (j, j + 1) with i = j + 1 cannot be the closest: the
        // new interval lies inside their gap, nearer to both.
        const float inf = std::numeric_limits<float>::infinity();
        const float gap_front = i > 0 ? lo - m_fragments[i - 1].far : inf;
        const float gap_back = i < m_count ? m_fragments[i].near - hi : inf;
        int pair = -1;
        float pair_gap = inf;
        for (int j = 0; j + 1 < m_count; ++j) {
            const float gap = m_fragments[j + 1].near - m_fragments[j].far;
            if (gap < pair_gap) {
                pair_gap = gap;
                pair = j;
            }
        }
        if (pair >= 0 && pair_gap < std::min(gap_front, gap_back)) {
            m_fragments[pair].surface =
                merged_surface(m_fragments[pair].surface, m_fragments[pair + 1].surface);
            absorb(m_fragments[pair], m_fragments[pair + 1]);
            erase(pair + 1, 1);
            if (i > pair + 1) {
                --i;
            }
            return true;
        }
        // United with a neighbour it stays clear of the other one: no cascade.
        FragmentType& f = gap_front <= gap_back ? m_fragments[i - 1] : m_fragments[i];
        accumulate(f, t, weight, opacity, attributes, mask);
        f.near = std::min(f.near, lo);
        f.far = std::max(f.far, hi);
        f.surface = merged_surface(f.surface, surface);
        return false;
    }

    std::array<FragmentType, Capacity> m_fragments{};
    int m_count = 0;  ///< Fragments in use, [0, Capacity].
    Compositing m_compositing = Compositing::Alpha;
    SamplePattern m_pattern = SamplePattern::Gaussian;
    ABufferStats m_stats;
    /// opaque_depth() of the fragments as they are, where m_opaque_known (insert and clear
    /// forget it).
    mutable float m_opaque = 0.0f;
    mutable bool m_opaque_known = false;
};

template <class A, int Capacity>
std::ostream& operator<<(std::ostream& os, const ABuffer<A, Capacity>& buffer) {
    os << "ABuffer{" << buffer.size() << '/' << Capacity << " fragments";
    for (const Fragment<A>& f : buffer.fragments()) {
        os << "\n  " << f;
    }
    return os << "\n  " << buffer.stats() << '}';
}

}  // namespace mrt
