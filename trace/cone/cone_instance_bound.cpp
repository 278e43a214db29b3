#include "trace/cone/cone_instance_bound.h"

#include <Eigen/SVD>

#include <cmath>

namespace mrt {

namespace {

/// How far a similarity's singular values may differ, relative to the largest, for the
/// group-space test to stand for the object-space one: a few roundings of the instance's matrix.
constexpr double kSimilarityTolerance = 1e-5;
/// Within this the map counts as a similarity for mapping the cone (map_cone_similar): a few
/// roundings of a float matrix, which the cone's own rounding already exceeds.
constexpr double kExactSimilarityTolerance = 1e-6;
/// A relative margin on the group-space sphere and widening: the tests in either space round
/// differently, and the group's must never be the one that rejects.
constexpr float kInstanceBoundMargin = 1e-4f;

}  // namespace

ConeInstanceBound instance_bound(const Vec3f& centre, float radius, float widening,
                                 const Affine3f& to_group) {
    ConeInstanceBound bound;
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(to_group.linear().cast<double>());
    const Eigen::Vector3d sigma = svd.singularValues();
    const double largest = sigma.maxCoeff();
    if (!(std::isfinite(largest) && largest > 0.0 &&
          sigma.minCoeff() >= largest * (1.0 - kSimilarityTolerance))) {
        return bound;
    }
    if (sigma.minCoeff() >= largest * (1.0 - kExactSimilarityTolerance)) {
        // The smallest stretch into the group is the largest into the object: the wider cone.
        bound.object_scale = static_cast<float>(1.0 / sigma.minCoeff());
    }
    const float scale = static_cast<float>(largest) * (1.0f + kInstanceBoundMargin);
    const Vec3f c = to_group * centre;
    bound.centre = {c.x(), c.y(), c.z()};
    bound.radius = radius * scale;
    bound.widening = widening * scale;
    bound.similarity =
        c.allFinite() && std::isfinite(bound.radius) && std::isfinite(bound.widening);
    return bound;
}

bool may_enter(const ConeInstanceBound& bound, const ConeRay& ray, const ConeSphereTest& test,
               float t_min, float t_max, SphereInRayFrame& sphere) {
    sphere = ray.sphere_of(Vec3f(bound.centre[0], bound.centre[1], bound.centre[2]), bound.radius);
    return !bound.similarity || test.circle_may_touch(sphere, bound.widening, t_min, t_max);
}

}  // namespace mrt
