#include "trace/bvh/bvh_build.h"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/parallel_invoke.h>
#include <oneapi/tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>

#include <emmintrin.h>

namespace mrt {
namespace {

/// Most bins per axis; small nodes use fewer (bin_count), since the sweep over the bins would
/// otherwise cost more than binning their few primitives.
constexpr int kBins = 32;

int bin_count(std::uint32_t n) {
    return static_cast<int>(std::min<std::uint32_t>(kBins, 4 + n / 4));
}
/// Subtrees with fewer primitives are built by the calling task (spawning costs more).
constexpr std::uint32_t kParallelSubtree = 2048;
/// Nodes with more primitives bin in parallel (only the top few levels).
constexpr std::uint32_t kParallelBinning = 32768;

/// A primitive's box; lane 3 of `lower` carries its index (never used as a coordinate).
struct alignas(16) PrimRef {
    float lower[3];
    std::uint32_t id;
    float upper[3];
    float pad;
};
static_assert(sizeof(PrimRef) == 32);

struct Box4 {
    __m128 lo = _mm_set1_ps(std::numeric_limits<float>::infinity());
    __m128 hi = _mm_set1_ps(-std::numeric_limits<float>::infinity());

    void extend(__m128 l, __m128 h) {
        lo = _mm_min_ps(lo, l);
        hi = _mm_max_ps(hi, h);
    }
    void extend(const Box4& b) { extend(b.lo, b.hi); }
    /// Half the surface area of a non-empty box (the SAH only needs ratios).
    float half_area() const {
        alignas(16) float d[4];
        _mm_store_ps(d, _mm_sub_ps(hi, lo));
        return d[0] * d[1] + d[1] * d[2] + d[2] * d[0];
    }
};

inline __m128 load_lower(const PrimRef& p) {
    return _mm_load_ps(p.lower);
}
inline __m128 load_upper(const PrimRef& p) {
    return _mm_load_ps(p.upper);
}
/// Twice the centroid: the factor ½ changes no comparison.
inline __m128 centroid2(const PrimRef& p) {
    return _mm_add_ps(load_lower(p), load_upper(p));
}

struct Bins {
    std::array<std::array<Box4, kBins>, 3> box;
    std::array<std::array<std::uint32_t, kBins>, 3> count{};

    void merge(const Bins& other) {
        for (int a = 0; a < 3; ++a) {
            for (int b = 0; b < kBins; ++b) {
                box[a][b].extend(other.box[a][b]);
                count[a][b] += other.count[a][b];
            }
        }
    }
};

/// Maps centroids to bins: bin = ⌊(c − c_min)·scale⌋ clamped to the last bin. The same float
/// operations bin a primitive and later partition it, so both always agree.
struct BinMapping {
    __m128 origin;
    __m128 scale;
    __m128 last;
    float origin_s[4];
    float scale_s[4];
    float last_s;
    int bins;

    int bin(float c2, int axis) const {
        const float f = std::min((c2 - origin_s[axis]) * scale_s[axis], last_s);
        return static_cast<int>(f);
    }
};

void bin_range(const PrimRef* refs, std::uint32_t begin, std::uint32_t end, const BinMapping& m,
               Bins& bins) {
    for (std::uint32_t i = begin; i < end; ++i) {
        const __m128 lo = load_lower(refs[i]);
        const __m128 hi = load_upper(refs[i]);
        const __m128 f =
            _mm_min_ps(_mm_mul_ps(_mm_sub_ps(_mm_add_ps(lo, hi), m.origin), m.scale), m.last);
        alignas(16) std::int32_t idx[4];
        _mm_store_si128(reinterpret_cast<__m128i*>(idx), _mm_cvttps_epi32(f));
        for (int a = 0; a < 3; ++a) {
            bins.box[a][idx[a]].extend(lo, hi);
            bins.count[a][idx[a]] += 1;
        }
    }
}

class Builder {
  public:
    Builder(std::span<const Eigen::AlignedBox3f> boxes, const BvhBuildOptions& options)
        : m_options(options),
          m_refs(boxes.size()),
          m_slots(2 * boxes.size() - 1),
          m_slot_used(m_slots.size(), 0) {
        assert(!boxes.empty());
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, boxes.size(), 4096),
                          [&](const tbb::blocked_range<std::size_t>& r) {
                              for (std::size_t i = r.begin(); i != r.end(); ++i) {
                                  PrimRef& p = m_refs[i];
                                  for (int a = 0; a < 3; ++a) {
                                      p.lower[a] = boxes[i].min()[a];
                                      p.upper[a] = boxes[i].max()[a];
                                  }
                                  p.id = static_cast<std::uint32_t>(i);
                                  p.pad = 0.0f;
                              }
                          });
    }

    BvhBuildResult run() {
        Box4 bounds, centroids;
        measure(0, static_cast<std::uint32_t>(m_refs.size()), bounds, centroids);
        build(0, 0, static_cast<std::uint32_t>(m_refs.size()), bounds, centroids, 0);
        return compact();
    }

  private:
    struct Split {
        int axis = -1;
        int bin = 0;
        float cost = std::numeric_limits<float>::infinity();  ///< Σ area·blocks of children.
    };

    std::uint32_t blocks(std::uint32_t n) const {
        return (n + m_options.leaf_block - 1) / m_options.leaf_block;
    }

    /// Box and centroid box of refs[begin, end).
    void measure(std::uint32_t begin, std::uint32_t end, Box4& bounds, Box4& centroids) const {
        const auto reduce = [&](std::uint32_t b, std::uint32_t e) {
            std::pair<Box4, Box4> r;
            for (std::uint32_t i = b; i < e; ++i) {
                const __m128 lo = load_lower(m_refs[i]);
                const __m128 hi = load_upper(m_refs[i]);
                r.first.extend(lo, hi);
                const __m128 c = _mm_add_ps(lo, hi);
                r.second.extend(c, c);
            }
            return r;
        };
        std::pair<Box4, Box4> r;
        if (end - begin >= kParallelBinning) {
            r = tbb::parallel_reduce(
                tbb::blocked_range<std::uint32_t>(begin, end, 8192), std::pair<Box4, Box4>{},
                [&](const tbb::blocked_range<std::uint32_t>& range, std::pair<Box4, Box4> acc) {
                    const auto part = reduce(range.begin(), range.end());
                    acc.first.extend(part.first);
                    acc.second.extend(part.second);
                    return acc;
                },
                [](std::pair<Box4, Box4> a, const std::pair<Box4, Box4>& b) {
                    a.first.extend(b.first);
                    a.second.extend(b.second);
                    return a;
                });
        } else {
            r = reduce(begin, end);
        }
        bounds = r.first;
        centroids = r.second;
    }

    Split find_split(std::uint32_t begin, std::uint32_t end, const Box4& centroids,
                     BinMapping& mapping) const {
        alignas(16) float cmin[4], cmax[4];
        _mm_store_ps(cmin, centroids.lo);
        _mm_store_ps(cmax, centroids.hi);
        bool any_extent = false;
        const int nb = bin_count(end - begin);
        mapping.bins = nb;
        mapping.last_s = float(nb - 1);
        mapping.last = _mm_set1_ps(mapping.last_s);
        for (int a = 0; a < 3; ++a) {
            const float extent = cmax[a] - cmin[a];
            // Slightly fewer than nb per extent, so the largest centroid stays in the last bin.
            const float scale = float(nb) * (1.0f - 1.0f / 1024.0f) / extent;
            const bool usable = extent > 0.0f && std::isfinite(scale);
            mapping.origin_s[a] = cmin[a];
            mapping.scale_s[a] = usable ? scale : 0.0f;
            any_extent = any_extent || usable;
        }
        mapping.origin_s[3] = 0.0f;
        mapping.scale_s[3] = 0.0f;
        mapping.origin = _mm_load_ps(mapping.origin_s);
        mapping.scale = _mm_load_ps(mapping.scale_s);
        if (!any_extent) {
            return {};
        }

        Bins bins;
        if (end - begin >= kParallelBinning) {
            // Box unions and counts are exact, so the merge order cannot change the result.
            bins = tbb::parallel_reduce(
                tbb::blocked_range<std::uint32_t>(begin, end, 8192), Bins{},
                [&](const tbb::blocked_range<std::uint32_t>& r, Bins acc) {
                    bin_range(m_refs.data(), r.begin(), r.end(), mapping, acc);
                    return acc;
                },
                [](Bins a, const Bins& b) {
                    a.merge(b);
                    return a;
                });
        } else {
            bin_range(m_refs.data(), begin, end, mapping, bins);
        }

        Split best;
        for (int a = 0; a < 3; ++a) {
            if (mapping.scale_s[a] == 0.0f) {
                continue;
            }
            // Right-to-left sweep: cost share of the right side of each candidate plane.
            std::array<float, kBins> right_cost{};
            Box4 acc;
            std::uint32_t right_count = 0;
            for (int b = nb - 1; b > 0; --b) {
                acc.extend(bins.box[a][b]);
                right_count += bins.count[a][b];
                right_cost[b] =
                    right_count == 0 ? 0.0f : acc.half_area() * float(blocks(right_count));
            }
            acc = Box4{};
            std::uint32_t left_count = 0;
            const std::uint32_t n = end - begin;
            for (int b = 1; b < nb; ++b) {
                acc.extend(bins.box[a][b - 1]);
                left_count += bins.count[a][b - 1];
                if (left_count == 0 || left_count == n) {
                    continue;
                }
                const float cost = acc.half_area() * float(blocks(left_count)) + right_cost[b];
                if (cost < best.cost) {
                    best = Split{a, b, cost};
                }
            }
        }
        return best;
    }

    void write_node(std::uint32_t slot, const Box4& bounds, std::uint32_t offset,
                    std::uint32_t count, std::uint32_t axis) {
        alignas(16) float lo[4], hi[4];
        _mm_store_ps(lo, bounds.lo);
        _mm_store_ps(hi, bounds.hi);
        BinaryBvhNode& node = m_slots[slot];
        for (int a = 0; a < 3; ++a) {
            node.lower[a] = lo[a];
            node.upper[a] = hi[a];
        }
        node.offset = offset;
        node.count = static_cast<std::uint16_t>(count);
        node.axis = static_cast<std::uint16_t>(axis);
        m_slot_used[slot] = 1;
    }

    /// Builds the subtree of refs[begin, end) into slots [slot, slot + 2n − 1): the left
    /// subtree takes the slots right after `slot`, the right one starts after the left's share,
    /// so concurrent subtrees never write the same slot and the slot order is depth-first.
    void build(std::uint32_t slot, std::uint32_t begin, std::uint32_t end, const Box4& bounds,
               const Box4& centroids, int depth) {
        const std::uint32_t n = end - begin;
        const auto make_leaf = [&] { write_node(slot, bounds, begin, n, 0); };
        if (n == 1) {
            make_leaf();
            return;
        }
        BinMapping mapping;
        const Split split =
            depth < kBvhSahDepth ? find_split(begin, end, centroids, mapping) : Split{};
        if (n <= m_options.max_leaf_size) {
            // Costs relative to the parent's area: C_t·A + C_i·Σ A_child·blocks versus the leaf's
            // C_i·A·blocks (multiplied out so flat or point-like boxes need no division).
            const float area = bounds.half_area();
            const float leaf = m_options.intersection_cost * area * float(blocks(n));
            const float inner =
                m_options.traversal_cost * area + m_options.intersection_cost * split.cost;
            if (split.axis < 0 || leaf <= inner) {
                make_leaf();
                return;
            }
        }

        std::uint32_t mid;
        int axis;
        if (split.axis >= 0) {
            axis = split.axis;
            mid = static_cast<std::uint32_t>(
                std::partition(m_refs.begin() + begin, m_refs.begin() + end,
                               [&](const PrimRef& p) {
                                   return mapping.bin(p.lower[axis] + p.upper[axis], axis) <
                                          split.bin;
                               }) -
                m_refs.begin());
        } else {
            // No SAH split (all centroids equal, or too deep): object median along the widest
            // centroid axis, ties broken by index so the order is fully determined.
            alignas(16) float ext[4];
            _mm_store_ps(ext, _mm_sub_ps(centroids.hi, centroids.lo));
            axis = ext[0] >= ext[1] ? (ext[0] >= ext[2] ? 0 : 2) : (ext[1] >= ext[2] ? 1 : 2);
            mid = begin + n / 2;
            std::nth_element(m_refs.begin() + begin, m_refs.begin() + mid, m_refs.begin() + end,
                             [axis](const PrimRef& a, const PrimRef& b) {
                                 const float ca = a.lower[axis] + a.upper[axis];
                                 const float cb = b.lower[axis] + b.upper[axis];
                                 return ca < cb || (ca == cb && a.id < b.id);
                             });
        }
        assert(mid > begin && mid < end);

        const std::uint32_t left_slot = slot + 1;
        const std::uint32_t right_slot = slot + 2 * (mid - begin);
        write_node(slot, bounds, right_slot, 0, static_cast<std::uint32_t>(axis));
        const auto left = [&] {
            Box4 b, c;
            measure(begin, mid, b, c);
            build(left_slot, begin, mid, b, c, depth + 1);
        };
        const auto right = [&] {
            Box4 b, c;
            measure(mid, end, b, c);
            build(right_slot, mid, end, b, c, depth + 1);
        };
        if (n >= kParallelSubtree) {
            tbb::parallel_invoke(left, right);
        } else {
            left();
            right();
        }
    }

    /// Drops the unused slots; depth-first order is kept, so first children still follow
    /// their parents.
    BvhBuildResult compact() {
        BvhBuildResult result;
        std::vector<std::uint32_t> new_index(m_slots.size(), 0);
        std::uint32_t next = 0;
        for (std::size_t s = 0; s < m_slots.size(); ++s) {
            if (m_slot_used[s] != 0) {
                new_index[s] = next++;
            }
        }
        result.nodes.reserve(next);
        for (std::size_t s = 0; s < m_slots.size(); ++s) {
            if (m_slot_used[s] != 0) {
                BinaryBvhNode node = m_slots[s];
                if (node.count == 0) {
                    node.offset = new_index[node.offset];
                }
                result.nodes.push_back(node);
            }
        }
        result.primitive_order.resize(m_refs.size());
        for (std::size_t i = 0; i < m_refs.size(); ++i) {
            result.primitive_order[i] = m_refs[i].id;
        }
        return result;
    }

    BvhBuildOptions m_options;
    std::vector<PrimRef> m_refs;
    std::vector<BinaryBvhNode> m_slots;
    /// One byte per slot (distinct objects, so concurrent subtrees can mark their own slots).
    std::vector<std::uint8_t> m_slot_used;
};

}  // namespace

BvhBuildResult build_bvh(std::span<const Eigen::AlignedBox3f> boxes,
                         const BvhBuildOptions& options) {
    if (boxes.empty()) {
        return {};
    }
    Builder builder(boxes, options);
    return builder.run();
}

}  // namespace mrt
