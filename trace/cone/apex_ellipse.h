#pragma once
// A cone whose footprint grows from nothing at its apex: a pinhole camera's primary cones, and
// what they become in an instance's space (a map takes a zero footprint to zero). Its footprint
// is F(t) = t·D, so its ellipse at depth t is t² times D's about the same axes, and the
// anisotropy clamp, a bound on the ratio of the axes, commutes with the scale. The traversal
// then decomposes D once per cone instead of F(t) at every node it looks at and every triangle
// vertex it weighs (a 2×2 eigen-decomposition in double precision, a chain of square roots and
// divisions: the largest single item of the complex scene's time profile).

#include "common/footprint/footprint.h"
#include "trace/cone/cone_triangle.h"

#include <cmath>

namespace mrt {

struct ApexEllipse {
    bool valid = false;        ///< False: the cone's footprint is not t·D (decompose F(t) itself).
    SymmetricEigen2 unit;      ///< D·Dᵀ's decomposition, as FootprintCone::ellipse_of gives it.
    GaussianFrame unit_frame;  ///< D's anisotropy-clamped frame: the frame at t = 1.

    /// D's decompositions where `cone` is t·D (not blurred, start_dev zero, D finite and not
    /// degenerate), else invalid.
    static ApexEllipse of(const FootprintCone& cone, float max_anisotropy) {
        ApexEllipse apex;
        if (cone.blurred || !(cone.start_dev.array() == 0.0f).all() || !cone.incr_dev.allFinite()) {
            return apex;
        }
        apex.unit = FootprintCone::ellipse_of(cone.incr_dev);
        if (!(apex.unit.major > 0.0f) || !std::isfinite(apex.unit.major)) {
            return apex;
        }
        // The clamp from the one decomposition (as the traversal's varying clusters clamp).
        SymmetricEigen2 clamped = apex.unit;
        FootprintCone::clamp_decomposed(cone.incr_dev, max_anisotropy, clamped);
        apex.unit_frame = GaussianFrame::of_ellipse(clamped);
        apex.valid = true;
        return apex;
    }

    /// Whether the ellipse at depth t comes from D's: t > 0 and its eigenvalues stay finite.
    bool covers(float t) const { return valid && t > 0.0f && std::isfinite(unit.major * t * t); }

    /// FootprintCone::ellipse_of(F(t)) for t that covers() accepts, to rounding.
    SymmetricEigen2 ellipse(float t) const {
        SymmetricEigen2 e = unit;
        e.major = unit.major * t * t;
        e.minor = unit.minor * t * t;
        return e;
    }

    /// GaussianFrame::of_clamped(F(t)) for t that covers() accepts, to rounding.
    GaussianFrame frame(float t) const {
        GaussianFrame f = unit_frame;
        f.inverse_semi_axes /= t;
        return f;
    }
};

}  // namespace mrt
