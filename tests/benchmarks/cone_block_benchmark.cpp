// The cone traversal's block tests, one member at a time (the `_scalar` references of
// trace/cone/cone_bound_block.h, inline, vectorised by the compiler as far as baseline x86-64
// allows) against the Highway kernels the traversal calls (dispatched at run time to the best
// instruction set the CPU has; the label names it). Each iteration tests one block, so the
// figures are nanoseconds per block, dispatch included: a cluster's 16 triangle bounding spheres
// against the cone's reach (and the same spheres as a node's clusters read from the arrays of all
// of them), a cluster's 16 point voxels against the clip, a node's 8 children
// against the cone's circle, and the points of a cluster the voxel test let through placed,
// tested and given their exponents (weigh_points), and the triangles of a cluster the spheres'
// test let through placed, mapped into the cull's frame and culled (triangles_within_cull). 512
// different random blocks (a few hundred kilobytes, in the second-level cache as a node's blocks
// are when the traversal reads them) are cycled through, so that the branch predictor does not
// learn one; 10 to 50 % of their members pass.

#include "common/footprint/footprint.h"
#include "common/footprint/point_weight.h"
#include "common/math/math.h"
#include "trace/cone/cone_block_simd.h"
#include "trace/cone/cone_bound_block.h"
#include "trace/cone/cone_bounds.h"
#include "trace/cone/cone_cluster_spheres.h"
#include "trace/cone/cone_point_lanes.h"
#include "trace/cone/cone_ray.h"
#include "trace/cone/cone_triangle.h"
#include "trace/cone/cone_triangle_block.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

namespace mrt {
namespace {

constexpr std::size_t kBlocks = 512;
static_assert(std::has_single_bit(kBlocks));

/// A primary cone of a 512-pixel-wide pinhole camera (about 2e-3 rad per pixel), from a random
/// origin in a random direction; every other one blurred as a depth-of-field cone is.
ConeRay random_ray(std::mt19937_64& rng) {
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    ConeRay ray;
    ray.origin = Vec3f(unit(rng), unit(rng), unit(rng)) * 10.0f;
    ray.direction = Vec3f(unit(rng), unit(rng), unit(rng)).normalized();
    orthonormal_basis(ray.direction, ray.cone.u, ray.cone.v);
    ray.cone.incr_dev = Mat2f::Identity() * 2e-3f;
    if (unit(rng) > 0.0f) {
        ray.cone.blurred = true;
        ray.cone.blur_start = Mat2f::Identity() * 0.02f;
        ray.cone.blur_incr = Mat2f::Identity() * -2e-3f;
    }
    return ray;
}

/// A point `t` along the ray, `distance` from its axis in a random direction.
Vec3f beside_axis(const ConeRay& ray, float t, float distance, std::mt19937_64& rng) {
    std::uniform_real_distribution<float> angle(0.0f, 2.0f * kPi);
    const float a = angle(rng);
    return ray.origin + t * ray.direction +
           distance * (std::cos(a) * ray.cone.u + std::sin(a) * ray.cone.v);
}

struct SphereCase {
    ConeRay ray;
    ConeBoundBlock block;
    std::uint32_t count = 0;
    float reach = 0.0f;
};

/// A cluster of a node's kept triangles: 16 spheres of a node's size apart, most clusters full.
const std::vector<SphereCase>& sphere_cases() {
    static const std::vector<SphereCase> cases = [] {
        std::mt19937_64 rng(61);
        std::uniform_real_distribution<float> positive(0.0f, 1.0f);
        std::vector<SphereCase> out(kBlocks);
        for (SphereCase& c : out) {
            c.ray = random_ray(rng);
            c.reach = 0.05f;
            c.count = positive(rng) < 0.8f ? kConeClusterSize
                                           : 1 + static_cast<std::uint32_t>(15 * positive(rng));
            const float t = 1.0f + 10.0f * positive(rng);
            for (std::uint32_t k = 0; k < c.count; ++k) {
                const Vec3f centre =
                    beside_axis(c.ray, t + 0.2f * positive(rng), 0.25f * positive(rng), rng);
                c.block.x[k] = centre.x();
                c.block.y[k] = centre.y();
                c.block.z[k] = centre.z();
                c.block.radius[k] = 0.05f * positive(rng);
            }
        }
        return out;
    }();
    return cases;
}

struct VoxelCase {
    ConeVoxelBlock block;
    VoxelGaussian voxels;
    std::uint32_t count = 0;
};

/// A cluster of a node's points (a 16³ grid) seen by a cone whose clip covers a few voxels.
const std::vector<VoxelCase>& voxel_cases() {
    static const std::vector<VoxelCase> cases = [] {
        std::mt19937_64 rng(67);
        std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
        std::uniform_real_distribution<float> positive(0.0f, 1.0f);
        std::uniform_int_distribution<int> index(0, 15);
        std::uniform_int_distribution<int> offset(-128, 127);
        std::vector<VoxelCase> out(kBlocks);
        for (VoxelCase& c : out) {
            c.voxels.clip = std::sqrt(kPointWeightClipExponent);
            c.voxels.offset_stretch = 0.002f;
            for (Vec2f& step : c.voxels.step) {
                step = Vec2f(unit(rng), unit(rng)) * 0.4f;
            }
            // The cone's axis through the node's middle, give or take a few voxels.
            c.voxels.first = -7.5f * (c.voxels.step[0] + c.voxels.step[1] + c.voxels.step[2]) +
                             Vec2f(unit(rng), unit(rng));
            c.count = positive(rng) < 0.8f ? kConeClusterSize
                                           : 1 + static_cast<std::uint32_t>(15 * positive(rng));
            for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
                c.block.x[k] = static_cast<std::uint8_t>(index(rng));
                c.block.y[k] = static_cast<std::uint8_t>(index(rng));
                c.block.z[k] = static_cast<std::uint8_t>(index(rng));
                c.block.offset[k] = static_cast<std::int8_t>(offset(rng));
            }
        }
        return out;
    }();
    return cases;
}

struct ChildCase {
    ConeRay ray;
    ConeSphereTest test;
    ConeChildBlock block;
    std::uint32_t count = 0;
};

/// A node's children (its octants' bounding spheres, half its side apart) near the cone, which
/// passes through some of them; nodes have 1 to 8 children, most of them 4 or more.
const std::vector<ChildCase>& child_cases() {
    static const std::vector<ChildCase> cases = [] {
        std::mt19937_64 rng(71);
        std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
        std::uniform_real_distribution<float> positive(0.0f, 1.0f);
        std::vector<ChildCase> out(kBlocks);
        for (ChildCase& c : out) {
            c.ray = random_ray(rng);
            c.test = ConeSphereTest(c.ray.cone, 8.0f);
            c.count = 1 + static_cast<std::uint32_t>(8 * std::sqrt(positive(rng)));
            c.count = std::min(c.count, kConeChildCount);
            const float side = 0.5f * std::pow(10.0f, unit(rng));
            const Vec3f node = beside_axis(c.ray, 5.0f + 5.0f * positive(rng), side, rng);
            for (std::uint32_t k = 0; k < c.count; ++k) {
                const Vec3f centre =
                    node + 0.25f * side *
                               Vec3f((k & 1) ? 1.0f : -1.0f, (k & 2) ? 1.0f : -1.0f,
                                     (k & 4) ? 1.0f : -1.0f);
                c.block.x[k] = centre.x();
                c.block.y[k] = centre.y();
                c.block.z[k] = centre.z();
                c.block.radius[k] = 0.45f * side;
                c.block.widening[k] = kPointKernelRadius * 0.5f * side / 16.0f;
            }
        }
        return out;
    }();
    return cases;
}

struct PointCase {
    PointLanesInput in;
    ConeVoxelBlock block;
    std::uint32_t candidates = 0;
    std::uint32_t count = 0;  ///< The candidates.
};

/// A cluster of a node's points (a 16³ grid, random normals) with the cone's axis through the
/// node and a footprint of a few voxels; the voxel test has let 4 to 16 of them through.
const std::vector<PointCase>& point_cases() {
    static const std::vector<PointCase> cases = [] {
        std::mt19937_64 rng(73);
        std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
        std::uniform_int_distribution<int> index(0, 15);
        std::uniform_int_distribution<int> offset(-127, 127);
        std::uniform_int_distribution<int> normal(0, 65535);
        std::uniform_int_distribution<std::uint32_t> mask(0, 0xffffu);
        // A closed surface seen from outside: its back faces are tested.
        static const ClosedSurface outward{{}, {}, 1.0f, 0.0f};
        std::vector<PointCase> out(kBlocks);
        for (PointCase& c : out) {
            const ConeRay ray = random_ray(rng);
            const float h = 0.01f;
            const Vec3f origin = beside_axis(ray, 5.0f, 0.02f, rng) - Vec3f::Constant(8.0f * h);
            const VertexInRayFrame first = ray.frame_of(origin + Vec3f::Constant(0.5f * h));
            c.in.first = {first.t, first.offset.x(), first.offset.y()};
            for (std::size_t a = 0; a < 3; ++a) {
                const auto i = static_cast<Eigen::Index>(a);
                c.in.step[a] = {h * ray.direction[i], h * ray.cone.u[i], h * ray.cone.v[i]};
            }
            c.in.direction = ray.direction;
            c.in.u = ray.cone.u;
            c.in.v = ray.cone.v;
            c.in.spacing = h;
            c.in.inverse = Mat2f::Identity() / (3.0f * h);
            c.in.t_min = 0.0f;
            c.in.t_max = 100.0f;
            c.in.closed = &outward;
            for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
                c.block.x[k] = static_cast<std::uint8_t>(index(rng));
                c.block.y[k] = static_cast<std::uint8_t>(index(rng));
                c.block.z[k] = static_cast<std::uint8_t>(index(rng));
                c.block.offset[k] = static_cast<std::int8_t>(offset(rng));
                c.block.normal_u[k] = static_cast<std::uint16_t>(normal(rng));
                c.block.normal_v[k] = static_cast<std::uint16_t>(normal(rng));
            }
            c.candidates = mask(rng) | mask(rng) | 0xfu;
            c.count = static_cast<std::uint32_t>(std::popcount(c.candidates));
        }
        return out;
    }();
    return cases;
}

struct TriangleCase {
    ConeRay ray;
    TriangleCull cull;
    ConeTriangleBlock block;
    std::uint32_t candidates = 0;
    std::uint32_t count = 0;  ///< The candidates.
};

/// A cluster of a mesh's triangles (each a few footprints across) around a point near the
/// cone's axis, culled with the footprint's frame at its depth and the traversal's reach; the
/// spheres' test has let 4 to 16 of them through.
const std::vector<TriangleCase>& triangle_cases() {
    static const std::vector<TriangleCase> cases = [] {
        std::mt19937_64 rng(79);
        std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
        std::uniform_int_distribution<std::uint32_t> mask(0, 0xffffu);
        std::vector<TriangleCase> out(kBlocks);
        for (TriangleCase& c : out) {
            c.ray = random_ray(rng);
            const float t = 5.0f;
            c.cull.t_min = 0.0f;
            c.cull.t_max = 100.0f;
            c.cull.frame = GaussianFrame::of(c.ray.cone.at(t));
            c.cull.reach = 1.25f * triangle_clip_radius(TriangleWeight::Coverage);
            const Vec3f centre = beside_axis(c.ray, t, 0.05f, rng);
            for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
                const Vec3f corner = centre + 0.04f * Vec3f(unit(rng), unit(rng), unit(rng));
                std::array<Vec3f, 3> p;
                for (Vec3f& vertex : p) {
                    vertex = corner + 0.02f * Vec3f(unit(rng), unit(rng), unit(rng));
                }
                c.block.set(k, p);
            }
            c.candidates = mask(rng) | mask(rng) | 0xfu;
            c.count = static_cast<std::uint32_t>(std::popcount(c.candidates));
        }
        return out;
    }();
    return cases;
}

/// Runs `test(case) -> mask` over the cases, one per iteration; then, untimed, counts the
/// members kept.
template <typename Case, typename Test>
void run_blocks(benchmark::State& state, const std::vector<Case>& cases, const Test& test) {
    std::size_t next = 0;
    for (auto _ : state) {
        const std::uint32_t mask = test(cases[next]);
        benchmark::DoNotOptimize(mask);
        next = (next + 1) % kBlocks;  // a power of two: a mask, not a division per block
    }
    std::int64_t kept = 0;
    std::int64_t members = 0;
    for (const Case& c : cases) {
        kept += std::popcount(test(c));
        members += c.count;
    }
    state.counters["kept_fraction"] = static_cast<double>(kept) / static_cast<double>(members);
    state.SetItemsProcessed(state.iterations());
}

void BM_SpheresNearAxisScalar(benchmark::State& state) {
    run_blocks(state, sphere_cases(), [](const SphereCase& c) {
        return spheres_near_axis_scalar(c.block, c.count, c.ray, c.reach, 0.0f, 100.0f);
    });
}
BENCHMARK(BM_SpheresNearAxisScalar);

void BM_SpheresNearAxisSimd(benchmark::State& state) {
    state.SetLabel(block_kernel_target());
    run_blocks(state, sphere_cases(), [](const SphereCase& c) {
        return spheres_near_axis(c.block, c.count, c.ray, c.reach, 0.0f, 100.0f);
    });
}
BENCHMARK(BM_SpheresNearAxisSimd);

/// The sphere cases' spheres as a node's clusters (clusters_near_axis): case i's at 16·i.
const ConeClusterSpheres& cluster_spheres() {
    struct Sphere {
        std::array<float, 3> centre;
        float radius;
    };
    static const ConeClusterSpheres spheres = [] {
        std::vector<Sphere> all;
        for (const SphereCase& c : sphere_cases()) {
            for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
                all.push_back({{c.block.x[k], c.block.y[k], c.block.z[k]}, c.block.radius[k]});
            }
        }
        return ConeClusterSpheres(all);
    }();
    return spheres;
}

/// The index of a sphere case, for the clusters' offset in cluster_spheres().
std::uint32_t case_index(const SphereCase& c) {
    return static_cast<std::uint32_t>(&c - sphere_cases().data());
}

void BM_ClustersNearAxisScalar(benchmark::State& state) {
    const ConeClusterSpheres& spheres = cluster_spheres();
    run_blocks(state, sphere_cases(), [&](const SphereCase& c) {
        return clusters_near_axis_scalar(spheres, kConeClusterSize * case_index(c), c.count, c.ray,
                                         c.reach, 0.0f, 100.0f);
    });
}
BENCHMARK(BM_ClustersNearAxisScalar);

void BM_ClustersNearAxisSimd(benchmark::State& state) {
    state.SetLabel(block_kernel_target());
    const ConeClusterSpheres& spheres = cluster_spheres();
    run_blocks(state, sphere_cases(), [&](const SphereCase& c) {
        return clusters_near_axis(spheres, kConeClusterSize * case_index(c), c.count, c.ray,
                                  c.reach, 0.0f, 100.0f);
    });
}
BENCHMARK(BM_ClustersNearAxisSimd);

void BM_VoxelsWithinClipScalar(benchmark::State& state) {
    run_blocks(state, voxel_cases(), [](const VoxelCase& c) {
        return voxels_within_clip_scalar(c.block, c.count, c.voxels);
    });
}
BENCHMARK(BM_VoxelsWithinClipScalar);

void BM_VoxelsWithinClipSimd(benchmark::State& state) {
    state.SetLabel(block_kernel_target());
    run_blocks(state, voxel_cases(),
               [](const VoxelCase& c) { return voxels_within_clip(c.block, c.count, c.voxels); });
}
BENCHMARK(BM_VoxelsWithinClipSimd);

void BM_ChildrenNearConeScalar(benchmark::State& state) {
    std::array<float, kConeChildCount> nearest{};
    run_blocks(state, child_cases(), [&](const ChildCase& c) {
        const std::uint32_t mask =
            children_near_cone_scalar(c.block, c.count, c.ray, c.test, 0.0f, 100.0f, nearest);
        benchmark::DoNotOptimize(nearest);
        return mask;
    });
}
BENCHMARK(BM_ChildrenNearConeScalar);

void BM_ChildrenNearConeSimd(benchmark::State& state) {
    state.SetLabel(block_kernel_target());
    std::array<float, kConeChildCount> nearest{};
    run_blocks(state, child_cases(), [&](const ChildCase& c) {
        const std::uint32_t mask =
            children_near_cone(c.block, c.count, c.ray, c.test, 0.0f, 100.0f, nearest);
        benchmark::DoNotOptimize(nearest);
        return mask;
    });
}
BENCHMARK(BM_ChildrenNearConeSimd);

void BM_WeighPointsScalar(benchmark::State& state) {
    PointLanes lanes;
    run_blocks(state, point_cases(), [&](const PointCase& c) {
        const std::uint32_t mask = weigh_points_scalar(c.block, c.candidates, c.in, lanes);
        benchmark::DoNotOptimize(lanes);
        return mask;
    });
}
BENCHMARK(BM_WeighPointsScalar);

void BM_WeighPointsSimd(benchmark::State& state) {
    state.SetLabel(block_kernel_target());
    PointLanes lanes;
    run_blocks(state, point_cases(), [&](const PointCase& c) {
        const std::uint32_t mask = weigh_points(c.block, c.candidates, c.in, lanes);
        benchmark::DoNotOptimize(lanes);
        return mask;
    });
}
BENCHMARK(BM_WeighPointsSimd);

void BM_TrianglesWithinCullScalar(benchmark::State& state) {
    run_blocks(state, triangle_cases(), [](const TriangleCase& c) {
        return triangles_within_cull_scalar(c.block, c.candidates, c.ray, c.cull);
    });
}
BENCHMARK(BM_TrianglesWithinCullScalar);

void BM_TrianglesWithinCullSimd(benchmark::State& state) {
    state.SetLabel(block_kernel_target());
    run_blocks(state, triangle_cases(), [](const TriangleCase& c) {
        return triangles_within_cull(c.block, c.candidates, c.ray, c.cull);
    });
}
BENCHMARK(BM_TrianglesWithinCullSimd);

}  // namespace
}  // namespace mrt

BENCHMARK_MAIN();
