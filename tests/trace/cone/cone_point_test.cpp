// Ray coordinates and the cone–point intersection of §4.3: frame_of agrees with a
// double-precision projection (also far from the origin), a point is weighed exactly as
// point_weight says and not at all behind t_min or edge-on; point_position puts a stored point
// on the surface (a sphere's points, decoded from the packed file records, lie much closer to
// the sphere than their voxel centres).

#include "trace/cone/cone_ray.h"

#include "common/hierarchy/hierarchy_file.h"
#include "common/mesh/procedural.h"
#include "preprocess/hierarchy_pack.h"
#include "preprocess/octree/point_octree.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace mrt {
namespace {

ConeRay ray_towards(const Vec3f& origin, const Vec3f& direction) {
    ConeRay ray;
    ray.origin = origin;
    ray.direction = direction.normalized();
    orthonormal_basis(ray.direction, ray.cone.u, ray.cone.v);
    ray.cone.incr_dev = 0.01f * Mat2f::Identity();
    return ray;
}

TEST(ConeRay, FrameOfAgreesWithADoublePrecisionProjectionEvenFarFromTheOrigin) {
    std::mt19937_64 rng(21);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    for (const float far : {0.0f, 1e4f}) {
        double worst = 0.0;
        for (int n = 0; n < 1000; ++n) {
            const Vec3f origin = Vec3f::Constant(far) + Vec3f(unit(rng), unit(rng), unit(rng));
            const ConeRay ray = ray_towards(origin, Vec3f(unit(rng), unit(rng), unit(rng)));
            const Vec3f p = origin + 3.0f * Vec3f(unit(rng), unit(rng), unit(rng));
            const VertexInRayFrame f = ray.frame_of(p);
            const Eigen::Vector3d d = p.cast<double>() - origin.cast<double>();
            worst = std::max({worst, std::abs(f.t - d.dot(ray.direction.cast<double>())),
                              std::abs(f.offset.x() - d.dot(ray.cone.u.cast<double>())),
                              std::abs(f.offset.y() - d.dot(ray.cone.v.cast<double>()))});
        }
        // A few float roundings of p − origin (|p − origin| ≤ 5.2), wherever the ray is.
        EXPECT_LT(worst, 5e-6) << "origin near " << far;
    }
}

TEST(ConePoint, WeighsAsPointWeightAndNotBehindTheStartOrEdgeOn) {
    const ConeRay ray = ray_towards(Vec3f(1, 2, 3), Vec3f(0, 0, -1));
    const float h = 0.05f;
    const PointWeightFrame frame = point_weight_frame(ray.cone, 10.0f, h, 8.0f);
    const Vec3f on_axis = ray.origin + 10.0f * ray.direction;
    const Vec3f facing(0, 0, 1);
    const auto hit = intersect_cone_point(ray, frame, on_axis, facing, 1.0f, 0.0f);
    ASSERT_TRUE(hit);
    EXPECT_NEAR(hit->t, 10.0f, 1e-5f);
    EXPECT_FLOAT_EQ(hit->weight, point_weight(frame, Vec2f::Zero(), -1.0f, 1.0f));
    // Off the axis by 0.05 along u: the weight of that offset.
    const Vec3f beside = on_axis + 0.05f * ray.cone.u;
    const auto off = intersect_cone_point(ray, frame, beside, facing, 0.5f, 0.0f);
    ASSERT_TRUE(off);
    EXPECT_NEAR(off->weight, point_weight(frame, Vec2f(0.05f, 0.0f), -1.0f, 0.5f), 1e-6f);
    EXPECT_LT(off->weight, hit->weight);
    // Behind t_min, edge-on, or outside the clip: nothing.
    EXPECT_FALSE(intersect_cone_point(ray, frame, on_axis, facing, 1.0f, 10.5f));
    EXPECT_FALSE(intersect_cone_point(ray, frame, on_axis, Vec3f(1, 0, 0), 1.0f, 0.0f));
    EXPECT_FALSE(intersect_cone_point(ray, frame, on_axis + ray.cone.v, facing, 1.0f, 0.0f));
}

TEST(PointPosition, PutsStoredPointsOnTheSurface) {
    const float r = 1.0f;
    const Mesh sphere = make_sphere(r, 96, 48, 0);
    const std::vector<Material> materials(1);
    const PointOctree octree = build_point_octree(sphere, materials, nullptr, {});
    const HierarchyData data = pack_hierarchy(octree, sphere, materials, "{}");
    double centre_error = 0.0, position_error = 0.0;
    std::size_t count = 0;
    for (std::size_t n = 0; n < data.nodes.size(); ++n) {
        const HierarchyNode& node = data.nodes[n];
        const OctreeNode& built = octree.nodes[n];
        const float voxel = node.side / static_cast<float>(data.grid);
        for (std::uint32_t i = 0; i < node.point_count; ++i) {
            const std::size_t k = node.first_point + i;
            const Vec3f p = point_position(node, data.grid, data.core[k], data.offset[k]);
            const OctreePoint& q = built.points[i];
            const Vec3f centre = built.voxel_centre(q.voxel, data.grid);
            // The decoded position is the octree's centre + offset·h·normal within the codecs'
            // bounds (offset ±1/254 h, normal 4.4e-5 rad over at most a voxel).
            EXPECT_LE((p - (centre + q.offset * voxel * q.normal)).norm(), 5e-3f * voxel);
            centre_error += std::abs(centre.norm() - r) / voxel;
            position_error += std::abs(p.norm() - r) / voxel;
            ++count;
        }
    }
    ASSERT_GT(count, 1000u);
    // Voxel centres lie on average a quarter voxel off a sphere; the surface points far less.
    EXPECT_GT(centre_error / static_cast<double>(count), 0.15);
    EXPECT_LT(position_error / static_cast<double>(count), 0.05);
}

}  // namespace
}  // namespace mrt
