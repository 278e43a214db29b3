// An instance's bound in its group's space (trace/cone/cone_instance_bound.h) answers as the
// instance root's own sphere test would after the cone is mapped into the instance: never "no"
// where the object-space test says "yes" (the traversal would lose geometry), and rarely "yes"
// where it says "no" (it would enter for nothing). And map_cone, which that rests on: under a
// similarity the mapped cone is the group's cone carried over by the map, and map_cone_similar's
// turned and scaled copy (with its sphere test's scaled coefficients) is the same cone.
//
// The reference for the first is ConeSphereTest in the object space map_cone gives; for the
// second, the group-space cone's axis and footprint ellipses pushed through the map.

#include "trace/cone/cone_instance_bound.h"

#include "trace/cone/cone_bounds.h"
#include "trace/cone/cone_ray.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace mrt {
namespace {

struct Instance {
    Affine3f to_group = Affine3f::Identity();
    Affine3f to_object = Affine3f::Identity();
};

/// A random similarity: rotation about a random axis, a scale from 1e-2 to 1e2, sometimes a
/// reflection, a translation of the scale's order.
Instance random_similarity(std::mt19937_64& rng) {
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    const float scale = std::pow(10.0f, 2.0f * unit(rng));
    const Vec3f axis = Vec3f(unit(rng), unit(rng), unit(rng)).normalized();
    Instance i;
    i.to_group =
        Eigen::Translation3f(Vec3f(unit(rng), unit(rng), unit(rng)) * 4.0f * scale) *
        Eigen::AngleAxisf(3.14159265f * unit(rng), axis) *
        Eigen::Scaling(unit(rng) < -0.6f ? Vec3f(-scale, scale, scale) : Vec3f::Constant(scale));
    i.to_object = i.to_group.inverse();
    return i;
}

/// A group-space cone from near the origin, anisotropic, sometimes blurred (shadow, lens).
ConeRay random_cone(std::mt19937_64& rng) {
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    ConeRay ray;
    ray.origin = Vec3f(unit(rng), unit(rng), unit(rng));
    ray.direction = Vec3f(unit(rng), unit(rng), unit(rng)).normalized();
    orthonormal_basis(ray.direction, ray.cone.u, ray.cone.v);
    ray.cone.incr_dev << unit(rng), unit(rng), unit(rng), unit(rng);
    ray.cone.incr_dev *= 0.05f;
    ray.cone.start_dev << unit(rng), unit(rng), unit(rng), unit(rng);
    ray.cone.start_dev *= 0.01f;
    if (unit(rng) > 0.0f) {
        ray.cone.blurred = true;
        ray.cone.blur_start << unit(rng), unit(rng), unit(rng), unit(rng);
        ray.cone.blur_start *= 0.02f;
        ray.cone.blur_incr << unit(rng), unit(rng), unit(rng), unit(rng);
        ray.cone.blur_incr *= 0.02f;
    }
    return ray;
}

TEST(ConeInstanceBound, MappedConeIsTheGroupsConeCarriedOverBySimilarities) {
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<float> positive(0.0f, 10.0f);
    for (int n = 0; n < 2000; ++n) {
        const ConeRay ray = random_cone(rng);
        const Instance instance = random_similarity(rng);
        const MappedCone mapped = map_cone(ray, instance.to_object);
        const float t = positive(rng);
        // The axis point and the footprint's columns at t, carried into object space, are the
        // mapped cone's at scale·t.
        const Vec3f axis_point = instance.to_object * (ray.origin + t * ray.direction);
        const Vec3f mapped_point = mapped.ray.origin + mapped.scale * t * mapped.ray.direction;
        const float size = axis_point.norm() + mapped.scale;
        EXPECT_LT((axis_point - mapped_point).norm(), 1e-5f * size);
        // The footprints' ellipses (their 3D second moments: a blurred footprint is a
        // symmetric root, whose columns turn with the frame's u and v).
        const Mat32f columns = instance.to_object.linear() * ray.cone.basis() * ray.cone.at(t);
        const Mat32f mapped_columns =
            mapped.ray.cone.basis() * mapped.ray.cone.at(mapped.scale * t);
        const Mat3f moments = columns * columns.transpose();
        const Mat3f mapped_moments = mapped_columns * mapped_columns.transpose();
        EXPECT_LT((moments - mapped_moments).norm(), 1e-5f * (moments.norm() + 1e-12f))
            << "scale " << mapped.scale;
    }
}

TEST(ConeInstanceBound, SimilarMapTurnsAndScalesTheConeAsTheGeneralMapDoes) {
    std::mt19937_64 rng(9);
    std::uniform_real_distribution<float> positive(0.0f, 10.0f);
    for (int n = 0; n < 2000; ++n) {
        const ConeRay ray = random_cone(rng);
        const Instance instance = random_similarity(rng);
        const ConeInstanceBound bound =
            instance_bound(Vec3f::Zero(), 1.0f, 0.0f, instance.to_group);
        ASSERT_GT(bound.object_scale, 0.0f);
        const MappedCone general = map_cone(ray, instance.to_object);
        const MappedCone similar = map_cone_similar(
            ray, instance.to_object, similarity_turn(instance.to_object, bound.object_scale),
            bound.object_scale);
        EXPECT_NEAR(similar.scale, general.scale, 1e-5f * general.scale);
        EXPECT_LT((similar.ray.origin - general.ray.origin).norm(),
                  1e-5f * (general.ray.origin.norm() + general.scale));
        EXPECT_LT((similar.ray.direction - general.ray.direction).norm(), 1e-5f);
        // An orthonormal frame around the axis, and the same footprint ellipses at every depth.
        EXPECT_NEAR(similar.ray.cone.u.norm(), 1.0f, 1e-5f);
        EXPECT_NEAR(similar.ray.cone.v.norm(), 1.0f, 1e-5f);
        EXPECT_NEAR(similar.ray.cone.u.dot(similar.ray.cone.v), 0.0f, 1e-5f);
        EXPECT_NEAR(similar.ray.cone.u.dot(similar.ray.direction), 0.0f, 1e-5f);
        const float t = general.scale * positive(rng);
        const Mat32f a = general.ray.cone.basis() * general.ray.cone.at(t);
        const Mat32f b = similar.ray.cone.basis() * similar.ray.cone.at(t);
        const Mat3f moments = a * a.transpose();
        EXPECT_LT((moments - b * b.transpose()).norm(), 1e-5f * (moments.norm() + 1e-12f));
        // The scaled sphere test bounds the mapped cone's Frobenius norm as a fresh one does.
        const ConeSphereTest parent(ray.cone, 8.0f);
        const ConeSphereTest scaled(parent, similar.ray.cone, bound.object_scale);
        const Mat2f f = similar.ray.cone.pixel_at(t);
        double exact = f.cast<double>().squaredNorm();
        if (similar.ray.cone.blurred) {
            exact += (similar.ray.cone.blur_start + t * similar.ray.cone.blur_incr)
                         .cast<double>()
                         .squaredNorm();
        }
        EXPECT_GE(static_cast<double>(scaled.frobenius_squared(t)), exact * (1.0 - 1e-6));
        EXPECT_LE(static_cast<double>(scaled.frobenius_squared(t)), exact * (1.0 + 1e-4) + 1e-12);
    }
}

TEST(ConeInstanceBound, GroupSpaceTestNeverRejectsWhatTheRootsOwnTestKeeps) {
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_real_distribution<float> positive(0.0f, 1.0f);
    const float max_anisotropy = 8.0f;
    int kept = 0;
    int rejected = 0;
    int entered_for_nothing = 0;
    for (int n = 0; n < 20000; ++n) {
        const ConeRay ray = random_cone(rng);
        const Instance instance = random_similarity(rng);
        const MappedCone mapped = map_cone(ray, instance.to_object);
        const float scale = mapped.scale;  // object units per group unit
        // An object root whose group-space sphere lies around the cone's clip ellipse's edge.
        const float t = 12.0f * positive(rng) - 1.0f;
        const Mat2f f = ray.cone.at(std::max(t, 0.0f));
        const Vec2f direction = Vec2f(unit(rng), unit(rng)).normalized();
        const float reach =
            std::sqrt(kPointWeightClipExponent) * (f.transpose() * direction).norm();
        const float group_radius = 0.2f * std::pow(10.0f, unit(rng));
        const Vec2f offset = direction * (reach + group_radius) * (0.7f + 0.6f * positive(rng));
        const Vec3f group_centre =
            ray.origin + t * ray.direction + offset.x() * ray.cone.u + offset.y() * ray.cone.v;
        const Vec3f centre = instance.to_object * group_centre;
        const float radius = group_radius * scale;
        const float widening = positive(rng) < 0.5f ? 0.0f : 0.05f * radius * positive(rng);
        const float t_min = positive(rng) < 0.5f ? 0.0f : 2.0f * positive(rng);
        const float t_max = positive(rng) < 0.5f ? 1e30f : t_min + 10.0f * positive(rng);

        const bool root_keeps = ConeSphereTest(mapped.ray.cone, max_anisotropy)
                                    .circle_may_touch(mapped.ray.sphere_of(centre, radius),
                                                      widening, t_min * scale, t_max * scale);
        const ConeInstanceBound bound = instance_bound(centre, radius, widening, instance.to_group);
        ASSERT_TRUE(bound.similarity);
        SphereInRayFrame sphere;
        const bool group_keeps =
            may_enter(bound, ray, ConeSphereTest(ray.cone, max_anisotropy), t_min, t_max, sphere);
        if (root_keeps) {
            ++kept;
            EXPECT_TRUE(group_keeps) << "case " << n << ": " << ray << ", scale " << scale;
        } else {
            ++rejected;
            entered_for_nothing += group_keeps ? 1 : 0;
        }
    }
    // Both outcomes are common (the check above is not vacuous), and the margins for rounding
    // let through almost nothing the root rejects.
    EXPECT_GT(kept, 4000);
    EXPECT_GT(rejected, 4000);
    EXPECT_LT(entered_for_nothing, rejected / 100);
    std::printf("  kept %d, rejected %d, of which the group's test kept %d\n", kept, rejected,
                entered_for_nothing);
}

TEST(ConeInstanceBound, UnevenScalesAndShearsAreAlwaysEntered) {
    const Affine3f stretched(Eigen::Scaling(Vec3f(1.0f, 2.0f, 1.0f)));
    Affine3f sheared = Affine3f::Identity();
    sheared.linear()(0, 1) = 0.3f;
    for (const Affine3f& to_group : {stretched, sheared}) {
        const ConeInstanceBound bound = instance_bound(Vec3f::Zero(), 1.0f, 0.0f, to_group);
        EXPECT_FALSE(bound.similarity);
        ConeRay far_away;
        far_away.origin = Vec3f(1e3f, 1e3f, 1e3f);
        SphereInRayFrame sphere;
        EXPECT_TRUE(
            may_enter(bound, far_away, ConeSphereTest(far_away.cone, 8.0f), 0.0f, 1e30f, sphere));
    }
    // Within a few roundings of a similarity still counts as one.
    const Affine3f nearly(Eigen::Scaling(Vec3f(3.0f, 3.0f * (1.0f + 2e-7f), 3.0f)));
    EXPECT_TRUE(instance_bound(Vec3f::Zero(), 1.0f, 0.0f, nearly).similarity);
}

}  // namespace
}  // namespace mrt
