// The per-ray A-buffer (trace/cone/abuffer.h) against independent references: fragments computed
// by grouping the inserted intersections by surface in double precision, the front-to-back
// blend written out analytically, the overflow policy on hand-placed intervals, allocation
// counted by a replaced operator new, and the point weights of a real octree of a flat quad
// (interior: one opaque fragment; edge: a translucent one).

#include "trace/cone/abuffer.h"

#include "common/footprint/footprint.h"
#include "common/footprint/point_weight.h"
#include "common/math/quantization.h"
#include "common/mesh/procedural.h"
#include "preprocess/octree/point_octree.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <new>
#include <numeric>
#include <random>
#include <sstream>
#include <tuple>
#include <type_traits>
#include <vector>

namespace {
/// Global allocations made since the start of the program (the replaced operator new below).
std::atomic<long> g_allocations{0};
}  // namespace

// Kept out of line: inlined, GCC sees free() of operator new's pointer and warns of a mismatch.
[[gnu::noinline]] void* operator new(std::size_t size) {
    g_allocations.fetch_add(1, std::memory_order_relaxed);
    if (void* p = std::malloc(size == 0 ? 1 : size)) {
        return p;
    }
    throw std::bad_alloc();
}
[[gnu::noinline]] void operator delete(void* p) noexcept {
    std::free(p);
}
[[gnu::noinline]] void operator delete(void* p, std::size_t) noexcept {
    std::free(p);
}

namespace mrt {
namespace {

/// A tracer-like record: a colour and a scalar averaged by weight, and an id sampled by nearest
/// neighbour (the contributor of the largest single weight), as §4.4 asks of normal gradients.
struct Surfel {
    Rgb colour = Rgb::Zero();
    float value = 0.0f;
    int id = -1;
    float id_weight = 0.0f;  ///< Weight of the contributor of `id`.

    void add(const Surfel& p, float w) {
        colour += w * p.colour;
        value += w * p.value;
        if (w > id_weight) {
            id = p.id;
            id_weight = w;
        }
    }
    void merge(const Surfel& o) {
        colour += o.colour;
        value += o.value;
        if (o.id_weight > id_weight) {
            id = o.id;
            id_weight = o.id_weight;
        }
    }
    Surfel averaged(float w) const {
        Surfel s = *this;
        s.colour /= w;
        s.value /= w;
        return s;
    }
};

/// A plain grey record: trivially copyable, so the buffer is too.
struct Grey {
    float grey = 0.0f;
    void add(const Grey& p, float w) { grey += w * p.grey; }
    void merge(const Grey& o) { grey += o.grey; }
    Grey averaged(float w) const { return Grey{grey / w}; }
};

static_assert(FragmentAttributes<Surfel>);
static_assert(FragmentAttributes<Grey>);
static_assert(!FragmentAttributes<int>);
static_assert(std::is_trivially_copyable_v<ABuffer<Grey>>);
// Fixed storage: the fragments inline, plus a count and the statistics.
static_assert(sizeof(ABuffer<Grey, 16>) <=
              16 * sizeof(Fragment<Grey>) + sizeof(ABufferStats) + 2 * alignof(ABufferStats));

/// One intersection to insert.
struct Hit {
    float t;
    float tolerance;
    float weight;
    Surfel surfel;
};

Surfel surfel(float r, float g, float b, float value, int id) {
    Surfel s;
    s.colour = Rgb(r, g, b);
    s.value = value;
    s.id = id;
    return s;
}

/// The fragment a set of hits of one surface must form, in double.
struct ExpectedFragment {
    double near = std::numeric_limits<double>::infinity();
    double far = -std::numeric_limits<double>::infinity();
    double weight = 0.0;
    double weighted_depth = 0.0;
    Eigen::Array3d colour = Eigen::Array3d::Zero();  ///< Σ w·c until finish(), then the mean.
    double value = 0.0;
    int id = -1;
    float id_weight = 0.0f;

    void add(const Hit& h) {
        near = std::min(near, static_cast<double>(h.t) - h.tolerance);
        far = std::max(far, static_cast<double>(h.t) + h.tolerance);
        weight += h.weight;
        weighted_depth += static_cast<double>(h.weight) * h.t;
        colour += static_cast<double>(h.weight) * h.surfel.colour.cast<double>();
        value += static_cast<double>(h.weight) * h.surfel.value;
        if (h.weight > id_weight) {
            id = h.surfel.id;
            id_weight = h.weight;
        }
    }
    Eigen::Array3d mean_colour() const { return colour / weight; }
};

/// The reference blend of fragments front to back, in double: Σ T_i·α_i·c_i, T = Π (1 − α_i).
struct ExpectedComposite {
    Eigen::Array3d radiance = Eigen::Array3d::Zero();
    double transmittance = 1.0;
};
ExpectedComposite blend(const std::vector<ExpectedFragment>& fragments) {
    ExpectedComposite r;
    for (const ExpectedFragment& f : fragments) {
        const double alpha = std::min(1.0, f.weight);
        r.radiance += r.transmittance * alpha * f.mean_colour();
        r.transmittance *= 1.0 - alpha;
    }
    return r;
}

template <int N>
void insert_all(ABuffer<Surfel, N>& buffer, const std::vector<Hit>& hits) {
    for (const Hit& h : hits) {
        buffer.insert(h.t, h.tolerance, h.weight, h.surfel);
    }
}

const auto kShadeColour = [](const Surfel& s, const Fragment<Surfel>&) -> Rgb { return s.colour; };

template <int N>
void expect_fragments(const ABuffer<Surfel, N>& buffer,
                      const std::vector<ExpectedFragment>& expected) {
    ASSERT_EQ(buffer.size(), static_cast<int>(expected.size())) << buffer;
    for (int i = 0; i < buffer.size(); ++i) {
        const Fragment<Surfel>& f = buffer[i];
        const ExpectedFragment& e = expected[static_cast<std::size_t>(i)];
        // Interval ends are single float sums t ± tolerance, whichever point set them.
        EXPECT_NEAR(f.near, e.near, 1e-6 * std::abs(e.near) + 1e-7) << buffer;
        EXPECT_NEAR(f.far, e.far, 1e-6 * std::abs(e.far) + 1e-7) << buffer;
        // Float sums of up to ~100 terms: relative error well below 1e-5.
        EXPECT_NEAR(f.weight, e.weight, 1e-5 * e.weight) << buffer;
        EXPECT_NEAR(f.depth(), e.weighted_depth / e.weight, 1e-5 * std::abs(e.far)) << buffer;
        const Surfel a = f.sums.averaged(f.weight);
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(a.colour[c], e.mean_colour()[c], 1e-5) << buffer;
        }
        EXPECT_NEAR(a.value, e.value / e.weight, 1e-5 * (1.0 + std::abs(e.value / e.weight)));
        EXPECT_EQ(a.id, e.id) << buffer;
    }
}

template <int N>
void expect_composite(const ABuffer<Surfel, N>& buffer, const ExpectedComposite& expected) {
    const CompositeResult r = buffer.composite(kShadeColour);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(r.radiance[c], expected.radiance[c], 2e-5) << buffer;
    }
    EXPECT_NEAR(r.transmittance, expected.transmittance, 2e-6) << buffer;
}

// ---------------------------------------------------------------------------------------------
// Merging

TEST(ABufferMerge, PointsOfOneSurfaceFormOneFragmentWithTheirWeightedMean) {
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<float> jitter(-0.01f, 0.01f);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::vector<Hit> hits;
    ExpectedFragment expected;
    for (int i = 0; i < 60; ++i) {
        // |t_i − t_j| ≤ 0.02 ≤ 2·tolerance: every pair of intervals overlaps.
        const Hit h{5.0f + jitter(rng), 0.01f + 0.01f * unit(rng), 0.01f + 0.2f * unit(rng),
                    surfel(unit(rng), unit(rng), unit(rng), 100.0f * unit(rng), i)};
        hits.push_back(h);
        expected.add(h);
    }
    ABuffer<Surfel> buffer;
    insert_all(buffer, hits);
    expect_fragments(buffer, {expected});
    EXPECT_EQ(buffer.stats().inserted, 60u);
    EXPECT_EQ(buffer.stats().merged, 59u);
    EXPECT_EQ(buffer.stats().forced_merges, 0u);
}

TEST(ABufferMerge, TouchingIntervalsMergeAndDisjointOnesDoNot) {
    ABuffer<Surfel> buffer;
    buffer.insert(1.0f, 0.25f, 0.5f, surfel(1, 0, 0, 0, 0));
    buffer.insert(1.5f, 0.25f, 0.5f, surfel(0, 1, 0, 0, 1));  // [1.25, 1.75] touches [0.75, 1.25]
    EXPECT_EQ(buffer.size(), 1) << buffer;
    buffer.insert(2.0f, 0.24f, 0.5f, surfel(0, 0, 1, 0, 2));  // [1.76, 2.24]: a gap of 0.01
    EXPECT_EQ(buffer.size(), 2) << buffer;
}

TEST(ABufferMerge, APointBridgingTwoFragmentsMergesAllThree) {
    ABuffer<Surfel> buffer;
    std::vector<Hit> hits = {{1.0f, 0.1f, 0.3f, surfel(1, 0, 0, 1, 0)},
                             {1.5f, 0.1f, 0.4f, surfel(0, 1, 0, 2, 1)},
                             {3.0f, 0.1f, 0.2f, surfel(0, 0, 1, 3, 2)}};
    insert_all(buffer, hits);
    ASSERT_EQ(buffer.size(), 3);
    // [1.05, 1.45] reaches [0.9, 1.1] and [1.4, 1.6], not [2.9, 3.1].
    const Hit bridge{1.25f, 0.2f, 0.1f, surfel(1, 1, 1, 4, 3)};
    buffer.insert(bridge.t, bridge.tolerance, bridge.weight, bridge.surfel);
    ExpectedFragment front, back;
    front.add(hits[0]);
    front.add(hits[1]);
    front.add(bridge);
    back.add(hits[2]);
    expect_fragments(buffer, {front, back});
    EXPECT_EQ(buffer.stats().cascaded, 1u);

    // A wide interval from the front reaching through a chain of four fragments.
    ABuffer<Surfel> chain;
    std::vector<Hit> links;
    for (int i = 0; i < 5; ++i) {
        links.push_back({1.0f + static_cast<float>(i), 0.1f, 0.1f, surfel(0, 0, 0, 1, i)});
    }
    insert_all(chain, links);
    ASSERT_EQ(chain.size(), 5);
    const Hit wide{2.0f, 2.0f, 0.05f, surfel(1, 1, 1, 0, 9)};  // [0, 4]: links at 1, 2, 3, 4
    chain.insert(wide.t, wide.tolerance, wide.weight, wide.surfel);
    ExpectedFragment merged, last;
    for (int i = 0; i < 4; ++i) {
        merged.add(links[static_cast<std::size_t>(i)]);
    }
    merged.add(wide);
    last.add(links[4]);
    expect_fragments(chain, {merged, last});
    EXPECT_EQ(chain.stats().cascaded, 3u);  // the one it first overlapped absorbed three more
}

// ---------------------------------------------------------------------------------------------
// Order independence

/// Hits of `surfaces` surfaces, `per_surface` each, the surfaces 1 apart and their points
/// within ±spread/2 of its depth with tolerances in [0.02, 0.04]: 0.7 clear of the next surface.
/// With spread ≤ 0.04 every two intervals of a surface overlap; with a wider spread only a chain
/// of them does, so which fragments meet depends on the insertion order and the cascade must
/// join them. The precondition — each surface's intervals form one chain — is checked here, by
/// a sweep over them sorted by their front, in double.
std::vector<Hit> layered_hits(int surfaces, int per_surface, float spread, std::uint64_t seed,
                              std::vector<ExpectedFragment>& expected) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::vector<Hit> hits;
    expected.assign(static_cast<std::size_t>(surfaces), ExpectedFragment{});
    for (int s = 0; s < surfaces; ++s) {
        std::vector<Hit> surface;
        for (int p = 0; p < per_surface; ++p) {
            const Hit h{2.0f + static_cast<float>(s) + spread * (unit(rng) - 0.5f),
                        0.02f + 0.02f * unit(rng),
                        (0.6f + unit(rng)) / static_cast<float>(per_surface) * 0.5f,
                        surfel(unit(rng), unit(rng), unit(rng), unit(rng), s * 1000 + p)};
            surface.push_back(h);
            expected[static_cast<std::size_t>(s)].add(h);
        }
        std::sort(surface.begin(), surface.end(),
                  [](const Hit& a, const Hit& b) { return a.t - a.tolerance < b.t - b.tolerance; });
        double reach = -std::numeric_limits<double>::infinity();
        for (std::size_t i = 0; i < surface.size(); ++i) {
            const double near = static_cast<double>(surface[i].t) - surface[i].tolerance;
            EXPECT_TRUE(i == 0 || near < reach - 1e-4) << "surface " << s << " is not one chain";
            reach = std::max(reach, static_cast<double>(surface[i].t) + surface[i].tolerance);
        }
        hits.insert(hits.end(), surface.begin(), surface.end());
    }
    return hits;
}

TEST(ABufferOrder, SeparateSurfacesStayApartInDepthOrderForEveryInsertionOrder) {
    std::vector<ExpectedFragment> expected;
    std::vector<Hit> hits = layered_hits(3, 2, 0.04f, 7, expected);
    const ExpectedComposite reference = blend(expected);
    std::vector<int> order(hits.size());
    std::iota(order.begin(), order.end(), 0);
    int permutations = 0;
    do {
        ABuffer<Surfel> buffer;
        for (const int i : order) {
            const Hit& h = hits[static_cast<std::size_t>(i)];
            buffer.insert(h.t, h.tolerance, h.weight, h.surfel);
        }
        expect_fragments(buffer, expected);
        expect_composite(buffer, reference);
        ++permutations;
    } while (std::next_permutation(order.begin(), order.end()) && !::testing::Test::HasFailure());
    EXPECT_EQ(permutations, 720);
}

TEST(ABufferOrder, RandomShufflesOfManyPointsGiveTheSameFragmentsAndComposite) {
    std::vector<ExpectedFragment> expected;
    std::vector<Hit> hits = layered_hits(6, 25, 0.2f, 11, expected);
    const ExpectedComposite reference = blend(expected);
    EXPECT_GT(reference.transmittance, 1e-3);  // translucent layers: every one shows
    std::mt19937_64 rng(3);
    ABufferStats total;
    for (int shuffle = 0; shuffle < 300 && !::testing::Test::HasFailure(); ++shuffle) {
        std::shuffle(hits.begin(), hits.end(), rng);
        ABuffer<Surfel> buffer;
        insert_all(buffer, hits);
        expect_fragments(buffer, expected);
        expect_composite(buffer, reference);
        total += buffer.stats();
    }
    EXPECT_EQ(total.forced_merges, 0u);
    EXPECT_GT(total.cascaded, 100u);  // the orders did split surfaces that later points joined
}

// ---------------------------------------------------------------------------------------------
// Compositing and opacity

TEST(ABufferComposite, BlendsFrontToBackAsTheAnalyticFormula) {
    const Rgb c1(0.2f, 0.4f, 0.8f), c2(1.0f, 0.5f, 0.0f), c3(0.3f, 0.3f, 0.9f);
    {
        // Weights 0.5 and 2: 0.5·c1 + 0.5·min(1, 2)·c2, nothing left behind.
        ABuffer<Surfel> buffer;
        buffer.insert(2.0f, 0.1f, 2.0f, surfel(c2[0], c2[1], c2[2], 0, 1));
        buffer.insert(1.0f, 0.1f, 0.5f, surfel(c1[0], c1[1], c1[2], 0, 0));
        const CompositeResult r = buffer.composite(kShadeColour);
        EXPECT_TRUE(((r.radiance - (0.5f * c1 + 0.5f * c2)).abs() < 1e-6f).all()) << r;
        EXPECT_EQ(r.transmittance, 0.0f);
    }
    {
        // One fragment of weight 0.25: 0.25·c, three quarters of the background.
        ABuffer<Surfel> buffer;
        buffer.insert(1.0f, 0.1f, 0.25f, surfel(c1[0], c1[1], c1[2], 0, 0));
        const CompositeResult r = buffer.composite(kShadeColour);
        EXPECT_TRUE(((r.radiance - 0.25f * c1).abs() < 1e-6f).all()) << r;
        EXPECT_FLOAT_EQ(r.transmittance, 0.75f);
    }
    {
        // Three halves: 0.5·c1 + 0.25·c2 + 0.125·c3, T = 1/8.
        ABuffer<Surfel> buffer;
        buffer.insert(3.0f, 0.1f, 0.5f, surfel(c3[0], c3[1], c3[2], 0, 2));
        buffer.insert(1.0f, 0.1f, 0.5f, surfel(c1[0], c1[1], c1[2], 0, 0));
        buffer.insert(2.0f, 0.1f, 0.5f, surfel(c2[0], c2[1], c2[2], 0, 1));
        const CompositeResult r = buffer.composite(kShadeColour);
        EXPECT_TRUE(((r.radiance - (0.5f * c1 + 0.25f * c2 + 0.125f * c3)).abs() < 1e-6f).all())
            << r;
        EXPECT_FLOAT_EQ(r.transmittance, 0.125f);
    }
    {
        // Empty: nothing, everything behind shows.
        const CompositeResult r = ABuffer<Surfel>{}.composite(kShadeColour);
        EXPECT_TRUE((r.radiance == 0.0f).all());
        EXPECT_EQ(r.transmittance, 1.0f);
    }
}

TEST(ABufferComposite, ShadesTheWeightedMeanAtTheMeanDepthAndStopsAtAnOpaqueFragment) {
    ABuffer<Surfel> buffer;
    // One surface of two points: mean colour (1·a + 3·b)/4 at depth (1·1.0 + 3·1.1)/4.
    buffer.insert(1.0f, 0.1f, 0.25f, surfel(1, 0, 0, 0, 0));
    buffer.insert(1.1f, 0.1f, 0.75f, surfel(0, 1, 0, 0, 1));
    buffer.insert(5.0f, 0.1f, 0.5f, surfel(0, 0, 1, 0, 2));  // hidden
    int calls = 0;
    const CompositeResult r = buffer.composite([&](const Surfel& s, const Fragment<Surfel>& f) {
        ++calls;
        EXPECT_NEAR(f.depth(), (0.25 * 1.0 + 0.75 * 1.1), 1e-6);
        EXPECT_FLOAT_EQ(f.weight, 1.0f);
        EXPECT_EQ(s.id, 1);  // the nearest neighbour: the larger weight
        return Rgb(s.colour);
    });
    EXPECT_EQ(calls, 1);
    EXPECT_TRUE(((r.radiance - Rgb(0.25f, 0.75f, 0.0f)).abs() < 1e-6f).all()) << r;
    EXPECT_EQ(r.transmittance, 0.0f);
}

TEST(ABufferOpaqueDepth, IsInfiniteUntilTheAlphaReachesOneThenTheFarEndOfThatFragment) {
    const float inf = std::numeric_limits<float>::infinity();
    ABuffer<Surfel> buffer;
    EXPECT_EQ(buffer.opaque_depth(), inf);
    buffer.insert(1.0f, 0.1f, 0.5f, Surfel{});
    EXPECT_EQ(buffer.opaque_depth(), inf);  // T = 0.5
    buffer.insert(3.0f, 0.1f, 0.5f, Surfel{});
    EXPECT_EQ(buffer.opaque_depth(), inf);  // T = 0.25
    buffer.insert(2.0f, 0.1f, 0.6f, Surfel{});
    EXPECT_EQ(buffer.opaque_depth(), inf);  // T = 0.5·0.4·0.5 = 0.1
    buffer.insert(4.0f, 0.2f, 1.0f, Surfel{});
    EXPECT_FLOAT_EQ(buffer.opaque_depth(), 4.2f);  // alpha 1 reached at [3.8, 4.2]
    buffer.insert(3.05f, 0.1f, 0.5f, Surfel{});    // the layer at 3 becomes opaque, [2.9, 3.15]
    EXPECT_FLOAT_EQ(buffer.opaque_depth(), 3.15f);
    buffer.insert(0.95f, 0.1f, 0.7f, Surfel{});  // the front layer: weight 1.2
    EXPECT_FLOAT_EQ(buffer.opaque_depth(), 1.1f);

    // Within the tolerance: two layers of alpha 0.995 leave T = 2.5e-5 ≤ kOpaqueTransmittance.
    ABuffer<Surfel> nearly;
    nearly.insert(1.0f, 0.1f, 0.995f, Surfel{});
    EXPECT_EQ(nearly.opaque_depth(), inf);
    nearly.insert(2.0f, 0.1f, 0.995f, Surfel{});
    EXPECT_FLOAT_EQ(nearly.opaque_depth(), 2.1f);
    // ...and what starts behind it shows at most that much.
    ABuffer<Surfel> behind = nearly;
    behind.insert(3.0f, 0.1f, 1.0f, surfel(1, 1, 1, 0, 0));
    const CompositeResult with = behind.composite(kShadeColour);
    const CompositeResult without = nearly.composite(kShadeColour);
    EXPECT_LE((with.radiance - without.radiance).abs().maxCoeff(), kOpaqueTransmittance);
}

// ---------------------------------------------------------------------------------------------
// Coverage masks

/// The samples of the left or right half of the cross-section (x < 0 or x > 0).
CoverageMask half_mask(bool left) {
    const CoverageSamples& s = coverage_samples();
    CoverageMask mask = 0;
    for (std::size_t i = 0; i < kCoverageSamples; ++i) {
        if ((s.x[i] < 0.0f) == left) {
            mask |= CoverageMask{1} << i;
        }
    }
    return mask;
}

ABuffer<Surfel> masked_buffer() {
    ABuffer<Surfel> buffer;
    buffer.set_compositing(Compositing::Mask);
    return buffer;
}

TEST(ABufferMask, ComplementaryHalvesAddUpWhereAlphasWouldLeaveAQuarter) {
    // Two adjacent triangles at different depths, each over half the cone: weight 0.5 each.
    const Rgb c1(0.2f, 0.4f, 0.8f), c2(1.0f, 0.5f, 0.0f);
    const CoverageMask left = half_mask(true);
    const CoverageMask right = half_mask(false);
    ASSERT_EQ(left | right, kFullCoverage);
    ASSERT_EQ(left & right, 0u);
    const float share_left = mask_coverage(left);
    ABuffer<Surfel> alpha;
    ABuffer<Surfel> masked = masked_buffer();
    for (ABuffer<Surfel>* b : {&alpha, &masked}) {
        b->insert(1.0f, 0.1f, share_left, surfel(c1[0], c1[1], c1[2], 0, 0), left);
        b->insert(2.0f, 0.1f, 1.0f - share_left, surfel(c2[0], c2[1], c2[2], 0, 1), right);
    }
    const CompositeResult a = alpha.composite(kShadeColour);
    EXPECT_NEAR(a.transmittance, (1.0f - share_left) * share_left, 1e-6f);  // about a quarter
    const CompositeResult m = masked.composite(kShadeColour);
    EXPECT_EQ(m.transmittance, 0.0f);
    const Rgb expected = share_left * c1 + (1.0f - share_left) * c2;
    EXPECT_TRUE(((m.radiance - expected).abs() < 1e-6f).all()) << m;
    EXPECT_FLOAT_EQ(masked.opaque_depth(), 2.1f);
    EXPECT_EQ(alpha.opaque_depth(), std::numeric_limits<float>::infinity());
}

TEST(ABufferMask, TheBackOfAThinSolidHidesBehindItsFront) {
    // Front and back face of a thin solid over the same half of the cone: the half counts once.
    const Rgb front(1.0f, 0.0f, 0.0f), back(0.0f, 1.0f, 0.0f);
    const CoverageMask left = half_mask(true);
    ABuffer<Surfel> masked = masked_buffer();
    masked.insert(2.0f, 0.1f, 0.5f, surfel(back[0], back[1], back[2], 0, 1), left);
    masked.insert(1.0f, 0.1f, 0.5f, surfel(front[0], front[1], front[2], 0, 0), left);
    int shaded = 0;
    const CompositeResult m = masked.composite([&](const Surfel& s, const Fragment<Surfel>&) {
        ++shaded;
        return Rgb(s.colour);
    });
    EXPECT_EQ(shaded, 1);  // the back takes no sample and is not shaded
    EXPECT_FLOAT_EQ(m.transmittance, 1.0f - mask_coverage(left));
    EXPECT_TRUE(((m.radiance - mask_coverage(left) * front).abs() < 1e-6f).all()) << m;
    EXPECT_EQ(masked.opaque_depth(), std::numeric_limits<float>::infinity());
}

TEST(ABufferMask, HolesInASurfacesMaskDoNotShowWhatLiesBehind) {
    // A surface whose points' discs leave one sample uncovered, over a bright one: the hole is
    // closed (close_holes), nothing of the back shows, and the front counts as opaque.
    const CoverageMask holed = kFullCoverage & ~(CoverageMask{1} << 37);
    ABuffer<Surfel> masked = masked_buffer();
    masked.insert(1.0f, 0.1f, 1.0f, surfel(0.2f, 0.2f, 0.2f, 0, 0), holed);
    masked.insert(3.0f, 0.1f, 1.0f, surfel(10.0f, 10.0f, 10.0f, 0, 1), kFullCoverage);
    const CompositeResult m =
        masked.composite([](const Surfel& s, const Fragment<Surfel>&) { return Rgb(s.colour); });
    EXPECT_FLOAT_EQ(m.transmittance, 0.0f);
    EXPECT_TRUE(((m.radiance - Rgb::Constant(0.2f)).abs() < 1e-6f).all()) << m;
    EXPECT_FLOAT_EQ(masked.opaque_depth(), 1.1f);
    // An edge is not a hole: half a cone stays half.
    ABuffer<Surfel> half = masked_buffer();
    half.insert(1.0f, 0.1f, 0.5f, surfel(0.2f, 0.2f, 0.2f, 0, 0), half_mask(true));
    const CompositeResult h =
        half.composite([](const Surfel& s, const Fragment<Surfel>&) { return Rgb(s.colour); });
    EXPECT_NEAR(h.transmittance, 1.0f - mask_coverage(half_mask(true)), 1.5f / 64.0f);
}

TEST(ABufferMask, MergedIntersectionsUniteTheirMasksAndKeepTheirWeightedMeans) {
    const CoverageMask a = 0x00000000FFFF0000ull;
    const CoverageMask b = 0x0000FFFF00000000ull;
    const CoverageMask c = 0xFFFF00000000FFFFull;
    ABuffer<Surfel> masked = masked_buffer();
    masked.insert(1.0f, 0.1f, 0.25f, surfel(1, 0, 0, 0, 0), a);
    masked.insert(1.05f, 0.1f, 0.75f, surfel(0, 1, 0, 0, 1), b);  // overlaps: merges
    ASSERT_EQ(masked.size(), 1);
    EXPECT_EQ(masked[0].mask, a | b);
    // A fragment behind, then an interval bridging both: the cascade unites all three masks.
    masked.insert(1.5f, 0.1f, 0.5f, surfel(0, 0, 1, 0, 2), c);
    ASSERT_EQ(masked.size(), 2);
    masked.insert(1.3f, 0.2f, 0.5f, surfel(0, 0, 1, 0, 3), 0);
    ASSERT_EQ(masked.size(), 1);
    EXPECT_EQ(masked[0].mask, kFullCoverage);
    // The colour is the weighted mean of all four, over the whole cone.
    const CompositeResult m = masked.composite(kShadeColour);
    EXPECT_EQ(m.transmittance, 0.0f);
    EXPECT_TRUE(((m.radiance - Rgb(0.25f, 0.75f, 1.0f) / 2.0f).abs() < 1e-6f).all()) << m;
}

TEST(ABufferMask, ForcedMergesOfAFullBufferKeepTheirCoverage) {
    ABuffer<Surfel, 2> masked;
    masked.set_compositing(Compositing::Mask);
    masked.insert(1.0f, 0.01f, 0.3f, Surfel{}, 0x1);
    masked.insert(2.0f, 0.01f, 0.3f, Surfel{}, 0x2);
    masked.insert(2.1f, 0.01f, 0.3f, Surfel{}, 0x4);  // full: merges with the fragment at 2
    ASSERT_EQ(masked.size(), 2);
    EXPECT_EQ(masked.stats().forced_merges, 1u);
    EXPECT_EQ(masked[0].mask | masked[1].mask, 0x7u);
    EXPECT_EQ(masked[1].mask, 0x6u);
}

TEST(ABufferMask, TwoSurfacesCloserThanTheToleranceStayApart) {
    // A sheet of paper half a millimetre above a desk, both within one tolerance interval:
    // with alpha they average into one brown fragment; with masks each surface keeps its own
    // fragment and the paper, in front, takes the samples it covers, in either order of
    // insertion.
    const Rgb paper(0.9f, 0.9f, 0.9f), desk(0.4f, 0.2f, 0.1f);
    const CoverageMask half = half_mask(true);
    for (const bool paper_first : {true, false}) {
        ABuffer<Surfel> masked = masked_buffer();
        const auto insert_paper = [&] {
            masked.insert(1.0f, 0.01f, 0.5f, surfel(paper[0], paper[1], paper[2], 0, 0), half, 1);
        };
        const auto insert_desk = [&] {
            masked.insert(1.0005f, 0.01f, 1.0f, surfel(desk[0], desk[1], desk[2], 0, 1),
                          kFullCoverage, 2);
        };
        if (paper_first) {
            insert_paper();
            insert_desk();
        } else {
            insert_desk();
            insert_paper();
        }
        ASSERT_EQ(masked.size(), 2) << masked;
        const CompositeResult m = masked.composite(kShadeColour);
        const float share = mask_coverage(half);
        const Rgb expected = share * paper + (1.0f - share) * desk;
        EXPECT_TRUE(((m.radiance - expected).abs() < 1e-5f).all()) << m;
        EXPECT_FLOAT_EQ(m.transmittance, 0.0f);
        // One surface's intersections still merge.
        masked.insert(1.002f, 0.01f, 0.5f, surfel(paper[0], paper[1], paper[2], 0, 2), ~half, 1);
        EXPECT_EQ(masked.size(), 2);
    }
}

TEST(ABufferMask, AGroupsPointsMergeWithAnySurface) {
    // A group's points stand for the surfaces of many objects: they merge with whichever they
    // overlap, and the fragment they started becomes the surface's that joins it.
    ABuffer<Surfel> masked = masked_buffer();
    masked.insert(1.0f, 0.01f, 0.5f, surfel(1, 0, 0, 0, 0), 0x0F, kAnySurface);
    masked.insert(1.005f, 0.01f, 0.5f, surfel(0, 1, 0, 0, 1), 0xF0, 3);
    ASSERT_EQ(masked.size(), 1);
    EXPECT_EQ(masked[0].surface, 3u);
    EXPECT_EQ(masked[0].mask, 0xFFu);
    masked.insert(1.01f, 0.01f, 0.5f, surfel(0, 0, 1, 0, 2), 0xF00, 4);  // another surface
    EXPECT_EQ(masked.size(), 2);
    masked.insert(1.02f, 0.01f, 0.5f, surfel(0, 0, 1, 0, 3), 0xF000, kAnySurface);
    EXPECT_EQ(masked.size(), 2);  // into the first it overlaps, in order of fronts
    EXPECT_EQ(masked[0].mask | masked[1].mask, 0xFFFFu);
}

TEST(ABufferMask, SurfacesKeepTheirFragmentsOrderedAndDisjoint) {
    // Random insertions of a few surfaces, groups' points among them: the fragments stay in
    // order of their fronts, a surface's fragments never overlap each other, and nothing of
    // the inserted weight or coverage is lost while the buffer has room.
    std::mt19937 random(11);
    std::uniform_real_distribution<float> depth(1.0f, 3.0f);
    std::uniform_int_distribution<int> which(0, 3);
    for (int trial = 0; trial < 200; ++trial) {
        ABuffer<Surfel, 64> masked;
        masked.set_compositing(Compositing::Mask);
        double weight = 0.0;
        CoverageMask covered = 0;
        for (int i = 0; i < 30; ++i) {
            const int k = which(random);
            const std::uint32_t surface = k == 3 ? kAnySurface : static_cast<std::uint32_t>(k);
            const CoverageMask mask = CoverageMask{1} << (random() % 64);
            masked.insert(depth(random), 0.05f, 0.25f, surfel(0.5f, 0.5f, 0.5f, 0, i), mask,
                          surface);
            weight += 0.25;
            covered |= mask;
        }
        ASSERT_EQ(masked.stats().forced_merges, 0u);
        double kept = 0.0;
        CoverageMask united = 0;
        const auto fragments = masked.fragments();
        for (std::size_t i = 0; i < fragments.size(); ++i) {
            kept += fragments[i].weight;
            united |= fragments[i].mask;
            EXPECT_LE(fragments[i].near, fragments[i].far);
            if (i > 0) {
                EXPECT_LE(fragments[i - 1].near, fragments[i].near);
            }
            for (std::size_t j = 0; j < i; ++j) {
                if (same_surface(fragments[i].surface, fragments[j].surface)) {
                    EXPECT_TRUE(fragments[j].far < fragments[i].near ||
                                fragments[i].far < fragments[j].near)
                        << masked;
                }
            }
        }
        EXPECT_NEAR(kept, weight, 1e-4);
        EXPECT_EQ(united, covered);
    }
}

TEST(ABufferMask, AMaskSourceIsAskedOnceWithTheSamplesOfTheFragmentItJoins) {
    // A mask given as a callable (MaskSource) is made knowing what the fragment it joins holds,
    // and the buffer's fragments and composite come out as with the masks themselves.
    const CoverageMask left = half_mask(true);
    const CoverageMask right = half_mask(false);
    ABuffer<Surfel> given = masked_buffer();
    ABuffer<Surfel> asked = masked_buffer();
    std::vector<CoverageMask> held;
    const auto source = [&](CoverageMask mask) {
        return [&held, mask](CoverageMask fragment) {
            held.push_back(fragment);
            return mask;
        };
    };
    // One surface (id 0): left half, then right half merging into it; another (id 1) behind.
    const std::array<std::tuple<float, CoverageMask, int>, 3> hits{
        {{1.0f, left, 0}, {1.05f, right, 0}, {2.0f, left, 1}}};
    for (const auto& [t, mask, id] : hits) {
        given.insert(t, 0.1f, 0.5f, surfel(1, 0, 0, 0, id), mask, static_cast<std::uint32_t>(id));
        asked.insert(t, 0.1f, 0.5f, surfel(1, 0, 0, 0, id), source(mask),
                     static_cast<std::uint32_t>(id));
    }
    // A new fragment holds nothing yet; the merge sees the left half its fragment holds.
    EXPECT_EQ(held, (std::vector<CoverageMask>{0, left, 0}));
    ASSERT_EQ(asked.size(), given.size());
    for (int i = 0; i < given.size(); ++i) {
        EXPECT_EQ(asked[i].mask, given[i].mask) << i;
    }
    EXPECT_EQ(asked.opaque_depth(), given.opaque_depth());
    // A source that leaves out what the fragment holds changes nothing either.
    ABuffer<Surfel> lean = masked_buffer();
    for (const auto& [t, mask, id] : hits) {
        lean.insert(
            t, 0.1f, 0.5f, surfel(1, 0, 0, 0, id),
            [mask = mask](CoverageMask fragment) { return mask & ~fragment; },
            static_cast<std::uint32_t>(id));
    }
    EXPECT_EQ(lean[0].mask, kFullCoverage);
    EXPECT_EQ(lean.composite(kShadeColour).transmittance, 0.0f);
}

TEST(ABufferMask, AlphaCompositingIgnoresTheMasks) {
    // The same insertions with and without masks composite alike by alpha.
    std::mt19937 random(5);
    std::uniform_real_distribution<float> depth(1.0f, 5.0f);
    std::uniform_real_distribution<float> weight(0.05f, 0.8f);
    ABuffer<Surfel> with;
    ABuffer<Surfel> without;
    for (int i = 0; i < 40; ++i) {
        const float t = depth(random);
        const float w = weight(random);
        const Surfel s = surfel(w, 1.0f - w, t / 5.0f, 0, i);
        with.insert(t, 0.05f, w, s, static_cast<CoverageMask>(random()) << 32 | random());
        without.insert(t, 0.05f, w, s);
    }
    const CompositeResult a = with.composite(kShadeColour);
    const CompositeResult b = without.composite(kShadeColour);
    EXPECT_EQ(a.transmittance, b.transmittance);
    EXPECT_TRUE((a.radiance == b.radiance).all());
    EXPECT_EQ(with.opaque_depth(), without.opaque_depth());
}

// ---------------------------------------------------------------------------------------------
// Overflow and bad input

TEST(ABufferOverflow, MergesTheClosestNeighboursInDepthAndCountsIt) {
    // Four translucent fragments 1 apart; a fifth at 4.6 lies 0.4 behind the last one, closer
    // than any two fragments (0.8): it joins the last.
    {
        ABuffer<Surfel, 4> buffer;
        std::vector<Hit> hits;
        std::vector<ExpectedFragment> expected(4);
        for (int i = 0; i < 4; ++i) {
            hits.push_back({1.0f + static_cast<float>(i), 0.1f, 0.1f, surfel(0, 0, 0, 0, i)});
            expected[static_cast<std::size_t>(i)].add(hits.back());
        }
        insert_all(buffer, hits);
        const Hit extra{4.6f, 0.1f, 0.05f, surfel(1, 1, 1, 0, 9)};
        buffer.insert(extra.t, extra.tolerance, extra.weight, extra.surfel);
        expected[3].add(extra);
        expect_fragments(buffer, expected);
        EXPECT_EQ(buffer.stats().forced_merges, 1u);
        EXPECT_EQ(buffer.stats().dropped_weight, 0.0);
    }
    // Fragments at 1, 2, 2.3, 5 (gaps 0.8, 0.1, 2.5); a new one at 3.5 is 1.0 and 1.3 from its
    // neighbours: the pair 2, 2.3 merges instead and the new one gets a fragment of its own.
    {
        ABuffer<Surfel, 4> buffer;
        std::vector<Hit> hits;
        for (const float t : {5.0f, 2.3f, 1.0f, 2.0f}) {
            hits.push_back({t, 0.1f, 0.1f, surfel(t, 0, 0, 0, static_cast<int>(10 * t))});
        }
        insert_all(buffer, hits);
        const Hit extra{3.5f, 0.1f, 0.1f, surfel(1, 1, 1, 0, 35)};
        buffer.insert(extra.t, extra.tolerance, extra.weight, extra.surfel);
        std::vector<ExpectedFragment> expected(4);
        expected[0].add(hits[2]);
        expected[1].add(hits[3]);
        expected[1].add(hits[1]);
        expected[2].add(extra);
        expected[3].add(hits[0]);
        expect_fragments(buffer, expected);
        EXPECT_EQ(buffer.stats().forced_merges, 1u);
    }
}

TEST(ABufferOverflow, DropsOrEvictsOnlyWhatLiesBehindTheOpaqueDepth) {
    ABuffer<Surfel, 4> buffer;
    const Rgb front(0.9f, 0.1f, 0.1f);
    buffer.insert(1.0f, 0.1f, 1.0f, surfel(front[0], front[1], front[2], 0, 1));  // opaque
    buffer.insert(2.0f, 0.1f, 0.5f, surfel(0, 1, 0, 0, 2));
    buffer.insert(3.0f, 0.1f, 0.5f, surfel(0, 1, 0, 0, 3));
    buffer.insert(4.0f, 0.1f, 0.5f, surfel(0, 1, 0, 0, 4));
    ASSERT_TRUE(buffer.full());
    ASSERT_FLOAT_EQ(buffer.opaque_depth(), 1.1f);

    // Full and the new one behind the opaque depth: dropped.
    buffer.insert(5.0f, 0.1f, 0.75f, surfel(1, 1, 1, 0, 5));
    EXPECT_EQ(buffer.size(), 4);
    EXPECT_EQ(buffer[3].sums.id, 4);
    EXPECT_EQ(buffer.stats().dropped_insertions, 1u);
    EXPECT_DOUBLE_EQ(buffer.stats().dropped_weight, 0.75);

    // Full and the new one in front: the last fragment (behind the opaque depth) makes room.
    const Rgb nearer(0.1f, 0.1f, 0.8f);
    buffer.insert(0.5f, 0.1f, 0.5f, surfel(nearer[0], nearer[1], nearer[2], 0, 0));
    ASSERT_EQ(buffer.size(), 4);
    for (int i = 0; i < 4; ++i) {
        EXPECT_EQ(buffer[i].sums.id, i) << buffer;
    }
    EXPECT_EQ(buffer.stats().evicted_fragments, 1u);
    EXPECT_DOUBLE_EQ(buffer.stats().dropped_weight, 1.25);
    EXPECT_EQ(buffer.stats().forced_merges, 0u);
    const CompositeResult r = buffer.composite(kShadeColour);
    EXPECT_TRUE(((r.radiance - (0.5f * nearer + 0.5f * front)).abs() < 1e-6f).all()) << r;
    EXPECT_EQ(r.transmittance, 0.0f);

    // A point merging into the opaque fragment is still accepted, even with the buffer full.
    buffer.insert(1.05f, 0.1f, 0.25f, surfel(0, 0, 0, 0, 7));
    EXPECT_FLOAT_EQ(buffer[1].weight, 1.25f);
    EXPECT_FLOAT_EQ(buffer.opaque_depth(), 1.15f);
}

TEST(ABufferInput, IgnoresNonFiniteAndNonPositiveWeightsDepthsAndTolerances) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    ABuffer<Surfel> buffer;
    buffer.insert(1.0f, 0.1f, 0.5f, surfel(1, 1, 1, 1, 0));
    for (const float w : {nan, inf, -inf, -1.0f, 0.0f, -0.0f}) {
        buffer.insert(1.0f, 0.1f, w, surfel(1, 1, 1, 1, 1));
        buffer.insert(7.0f, 0.1f, w, surfel(1, 1, 1, 1, 1));
    }
    buffer.insert(nan, 0.1f, 0.5f, Surfel{});
    buffer.insert(inf, 0.1f, 0.5f, Surfel{});
    buffer.insert(1.0f, nan, 0.5f, Surfel{});
    buffer.insert(1.0f, inf, 0.5f, Surfel{});
    EXPECT_EQ(buffer.size(), 1) << buffer;
    EXPECT_EQ(buffer[0].weight, 0.5f);
    EXPECT_EQ(buffer.stats().ignored, 16u);
    EXPECT_EQ(buffer.stats().inserted, 1u);
    // A negative tolerance is a zero one: a point interval [3, 3].
    buffer.insert(3.0f, -1.0f, 0.25f, Surfel{});
    ASSERT_EQ(buffer.size(), 2);
    EXPECT_EQ(buffer[1].near, 3.0f);
    EXPECT_EQ(buffer[1].far, 3.0f);
    // A tiny positive weight is a weight.
    buffer.insert(9.0f, 0.0f, std::numeric_limits<float>::denorm_min(), Surfel{});
    EXPECT_EQ(buffer.size(), 3);
    const CompositeResult r = buffer.composite(kShadeColour);
    EXPECT_TRUE(r.radiance.isFinite().all() && std::isfinite(r.transmittance)) << r;
    EXPECT_TRUE(std::isfinite(buffer.opaque_depth()) || buffer.opaque_depth() == inf);
}

TEST(ABufferMemory, NeverAllocatesToInsertCompositeCopyOrClear) {
    std::vector<ExpectedFragment> expected;
    const std::vector<Hit> hits = layered_hits(20, 10, 0.04f, 5, expected);  // overflows 16
    ABuffer<Surfel, 16> buffer;
    const long before = g_allocations.load();
    float total = 0.0f;
    for (int ray = 0; ray < 50; ++ray) {
        buffer.clear();
        insert_all(buffer, hits);
        const ABuffer<Surfel, 16> copy = buffer;
        total += copy.composite(kShadeColour).transmittance + copy.opaque_depth();
    }
    const long after = g_allocations.load();
    EXPECT_EQ(after, before);
    // The counter counts: a vector's storage comes through it.
    std::vector<float> probe(100, 1.0f);
    EXPECT_GT(g_allocations.load(), after);
    total += probe[50];
    EXPECT_TRUE(buffer.full());
    // 20 layers of alpha ~0.55 are opaque after 12: the rest is dropped once the buffer fills.
    EXPECT_GT(buffer.stats().dropped_insertions, 0u);
    EXPECT_TRUE(std::isfinite(total));
    // clear() empties the fragments and the statistics.
    buffer.clear();
    EXPECT_TRUE(buffer.empty());
    EXPECT_EQ(buffer.stats().inserted, 0u);
    EXPECT_EQ(buffer.composite(kShadeColour).transmittance, 1.0f);
}

TEST(ABufferPrinting, ShowsEveryFragmentAndTheStatistics) {
    ABuffer<Grey, 4> buffer;
    buffer.insert(1.0f, 0.5f, 0.25f, Grey{0.5f});
    buffer.insert(3.0f, 0.5f, 0.5f, Grey{0.5f});
    std::ostringstream os;
    os << buffer;
    EXPECT_NE(os.str().find("2/4 fragments"), std::string::npos) << os.str();
    EXPECT_NE(os.str().find("[0.5, 1.5], weight 0.25"), std::string::npos) << os.str();
    EXPECT_NE(os.str().find("[2.5, 3.5], weight 0.5"), std::string::npos) << os.str();
    EXPECT_NE(os.str().find("inserted 2"), std::string::npos) << os.str();
}

// ---------------------------------------------------------------------------------------------
// The project's point weights

/// The points of one octree level of a flat quad, seen by a cone at normal incidence whose
/// axis pierces the quad's plane at (x, z), inserted with tolerance = the node's voxel side.
/// Returns the buffer and, independently, the weight sum in double.
struct QuadCone {
    ABuffer<Grey> buffer;
    double weight_sum = 0.0;
    int points = 0;
};

QuadCone cone_on_quad(const PointOctree& octree, int level, float x, float z) {
    QuadCone result;
    const int k = octree.options.grid;
    const Vec3f origin(x, 2.0f, z);
    const Vec3f d = -Vec3f::UnitY();
    const Vec3f u = Vec3f::UnitX();
    const Vec3f v = Vec3f::UnitZ();
    for (const OctreeNode& node : octree.nodes) {
        if (node.level != level) {
            continue;
        }
        const float h = node.side / static_cast<float>(k);
        // A footprint of semi-axes h: minimum diameter 2h ≥ h, so the traversal stops here.
        const PointWeightFrame frame = point_weight_frame(h * Mat2f::Identity(), h);
        for (const OctreePoint& p : node.points) {
            const Vec3f n = decode_normal(encode_normal(p.normal));
            const Vec3f position =
                node.voxel_centre(p.voxel, k) + decode_offset8(encode_offset8(p.offset)) * h * n;
            const Vec3f rel = position - origin;
            const float w = point_weight(frame, Vec2f(rel.dot(u), rel.dot(v)), n.dot(d),
                                         decode_coverage8(encode_coverage8(p.coverage)));
            if (w > 0.0f) {
                result.buffer.insert(rel.dot(d), h, w, Grey{1.0f});
                result.weight_sum += w;
                ++result.points;
            }
        }
    }
    return result;
}

TEST(ABufferPointWeight, AQuadsInteriorIsOneOpaqueFragmentAndItsEdgeATranslucentOne) {
    // A 2 × 2 quad of 32² tiles (small triangles: the top levels are all points), off the
    // octree's symmetry, facing +Y.
    Mesh quad = make_checkerboard(2.0f, 2.0f, 32, 32, 0, 0);
    for (Vec3f& p : quad.positions) {
        p += Vec3f(0.013f, 0.0f, -0.007f);
    }
    Material material;
    material.diffuse = Rgb(0.5f, 0.5f, 0.5f);
    const PointOctree octree = build_point_octree(quad, {material}, nullptr, {});
    // The root keeps no triangle: its points stand for the whole quad.
    ASSERT_TRUE(octree.nodes[0].triangles.empty());
    {
        const int level = 0;
        const QuadCone interior = cone_on_quad(octree, level, 0.1f, 0.2f);
        ASSERT_GT(interior.points, 4);
        ASSERT_EQ(interior.buffer.size(), 1) << "level " << level << interior.buffer;
        EXPECT_NEAR(interior.buffer[0].weight, interior.weight_sum, 1e-5 * interior.weight_sum);
        EXPECT_GE(interior.buffer[0].weight, 1.0f) << "level " << level;
        EXPECT_EQ(interior.buffer[0].alpha(), 1.0f);
        EXPECT_EQ(interior.buffer.opaque_depth(), interior.buffer[0].far);
        EXPECT_EQ(
            interior.buffer
                .composite([](const Grey&, const Fragment<Grey>&) { return Rgb(1.0f, 1.0f, 1.0f); })
                .transmittance,
            0.0f);

        // On the edge x = +1 (shifted by 0.013): about half the interior's sum.
        const QuadCone edge = cone_on_quad(octree, level, 1.013f, 0.2f);
        ASSERT_EQ(edge.buffer.size(), 1) << "level " << level << edge.buffer;
        EXPECT_NEAR(edge.buffer[0].weight, edge.weight_sum, 1e-5 * edge.weight_sum);
        EXPECT_GT(edge.buffer[0].weight, 0.0f);
        EXPECT_LT(edge.buffer[0].weight, 1.0f) << "level " << level;
        EXPECT_LT(edge.buffer[0].weight, 0.8f * interior.buffer[0].weight);
        std::printf("  quad level %d: interior weight %.3f (%d points), edge %.3f (%d points)\n",
                    level, interior.buffer[0].weight, interior.points, edge.buffer[0].weight,
                    edge.points);
        EXPECT_EQ(edge.buffer.opaque_depth(), std::numeric_limits<float>::infinity());
        const CompositeResult r = edge.buffer.composite(
            [](const Grey& g, const Fragment<Grey>&) { return Rgb(g.grey, g.grey, g.grey); });
        EXPECT_NEAR(r.transmittance, 1.0f - edge.buffer[0].weight, 1e-6f);
    }
}

}  // namespace
}  // namespace mrt
