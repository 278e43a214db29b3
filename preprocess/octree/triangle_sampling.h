#pragma once
// Area-uniform, deterministic sample points on a triangle for the point hierarchy (Wand &
// Straßer §3.2). The default points are a 2D Kronecker (R2) sequence, randomly rotated per
// triangle and node (Cranley–Patterson), mapped onto the triangle by the area-preserving
// square-to-triangle map: any prefix of n points is spread evenly over the triangle (low
// discrepancy), so the first samples of the dense prefiltering set double as the sparse set that
// chooses the representatives, and the result does not depend on the thread that draws them.
// The alternative is the paper's: independent uniform points (from a counter-based hash, so just
// as deterministic), kept to measure what the low-discrepancy points gain
// (docs/preprocess-sampling.md).

#include "common/math/math.h"
#include "common/system/enum_names.h"

#include <cstdint>

namespace mrt {

/// How the samples on a triangle are placed.
enum class TriangleSampling {
    LowDiscrepancy,  ///< Rotated R2 sequence: even spread, error falling about as 1/n.
    Random,          ///< Independent uniform points (as in the paper): error falling as 1/√n.
};

/// mrt-preprocess --sampling's names, also written to the file's build record.
inline constexpr EnumNames<TriangleSampling, 2> kTriangleSamplingNames{{{
    {TriangleSampling::LowDiscrepancy, "low-discrepancy"},
    {TriangleSampling::Random, "random"},
}}};

/// Barycentric coordinates (b1, b2) of sample `index` of the sequence chosen by `key`;
/// the point is (1 − b1 − b2)·p0 + b1·p1 + b2·p2, uniformly distributed over the area.
Vec2f triangle_sample(std::uint32_t index, std::uint64_t key,
                      TriangleSampling scheme = TriangleSampling::LowDiscrepancy);

/// Key of the samples of `triangle` in the octree node at `level`, for build seed `seed`.
std::uint64_t triangle_sample_key(std::uint64_t seed, std::uint32_t triangle, int level);

}  // namespace mrt
