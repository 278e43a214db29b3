#pragma once
// Rays, and the offset that moves a secondary ray's origin off the surface it starts on by the
// intersection's floating-point error bound instead of a fixed epsilon (no self-intersection at
// any scene scale).

#include "common/math/math.h"

#include <algorithm>
#include <cmath>
#include <iosfwd>

namespace mrt {

struct Ray {
    Vec3f origin{0.0f, 0.0f, 0.0f};     ///< World (or object) space origin.
    Vec3f direction{0.0f, 0.0f, 1.0f};  ///< Not necessarily unit length.
    float t_max = kInfinity;            ///< Segment end in units of |direction|.
};

/// Conservative bound on the absolute floating-point error of a surface point p computed by the
/// intersection routines (barycentric interpolation of vertices of magnitude ≤ |p| scale):
/// a few ulps of the largest coordinate involved.
inline float intersection_error_bound(const Vec3f& p, float vertex_magnitude) {
    const float magnitude = std::max(p.cwiseAbs().maxCoeff(), vertex_magnitude);
    constexpr float kUlpsOfError = 32.0f * std::numeric_limits<float>::epsilon();
    return kUlpsOfError * magnitude + std::numeric_limits<float>::min();
}

/// Origin for a ray leaving surface point p (geometric normal n_geometric, unit) in direction d:
/// p pushed along ±n by the error bound, to the side d goes to.
inline Vec3f offset_ray_origin(const Vec3f& p, const Vec3f& n_geometric, float error_bound,
                               const Vec3f& d) {
    const float side = n_geometric.dot(d) >= 0.0f ? 1.0f : -1.0f;
    return p + (side * error_bound) * n_geometric;
}

std::ostream& operator<<(std::ostream& os, const Ray& r);

}  // namespace mrt
