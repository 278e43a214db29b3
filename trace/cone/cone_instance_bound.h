#pragma once
// An instance's bound as its group sees it: the traversal tests a cone against it before mapping
// the cone into the instance's object space. A leaf of an instance tree holds up to four
// instances, and a cone that reaches the leaf misses about half of them (the field: 10.9 M of 20.4
// M entries at 320×240); each entry costs a new frame, a mapped footprint and a sphere test's
// coefficients before the root's own test rejects it.

#include "common/math/math.h"
#include "trace/cone/cone_bounds.h"
#include "trace/cone/cone_ray.h"

#include <array>

namespace mrt {

/// An instance's object root's bounding sphere in its group's space. Only where the instance's
/// map is a similarity (rotation, reflection, uniform scale): there the object-space cone is the
/// group's scaled (map_cone), so the group-space test answers as the root's own test would after
/// entering. Under shears and uneven scales the object-space cone is a first-order projection,
/// not a scaled copy, and such instances are always entered.
struct ConeInstanceBound {
    std::array<float, 3> centre{};
    float radius = 0.0f;    ///< Padded for the map's and the tests' rounding.
    float widening = 0.0f;  ///< The root's point kernel radius, in group units.
    bool similarity = false;
    /// Object length per group length, where the map is a similarity to within a few
    /// roundings of its float matrix, so that entering may use map_cone_similar; 0 elsewhere.
    float object_scale = 0.0f;
};

/// The bound of an object whose root sphere is (centre, radius) and whose root's points are
/// widened by `widening` (kPointKernelRadius times its spacing), placed by `to_group`.
ConeInstanceBound instance_bound(const Vec3f& centre, float radius, float widening,
                                 const Affine3f& to_group);

/// Whether the group-space cone `ray` (its sphere test `test`) may meet the instance between
/// t_min and t_max: true when the bound is not a similarity's, as the instance must be entered.
/// `sphere` receives the bound in the ray's frame.
bool may_enter(const ConeInstanceBound& bound, const ConeRay& ray, const ConeSphereTest& test,
               float t_min, float t_max, SphereInRayFrame& sphere);

}  // namespace mrt
