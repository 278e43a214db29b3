#pragma once
// The skeleton of a ray tree that every tracer shares (Whitted 1980: I = I_local + k_r·R + k_t·T):
// how the light leaving a surface divides between local scattering (ambient, diffuse and Phong
// from the lights), the refracted branch and the mirrored branch; which branches are worth
// tracing (Hall & Greenberg 1983); and which side of the surface a secondary direction must
// leave on. The whitted and distributed ray trees (trace/raytrace/ray_tree.h) and the cone tracer
// (trace/cone/cone_tracer.cpp) differ only in how they find the light and the directions: the
// weights, the pruning and the order of the sums are these.

#include "common/math/math.h"
#include "common/system/check.h"

#include <algorithm>

namespace mrt {

/// Branches of the ray tree whose contribution to the pixel is scaled below this are not traced
/// (Hall & Greenberg 1983, adaptive tree depth control): a tenth of an 8-bit step.
inline constexpr float kMinimumWeight = 1.0f / 2550.0f;

/// The share of the light a material scatters locally (ambient and Phong): what it neither
/// mirrors nor transmits.
inline float local_share(float reflectivity, float transparency) {
    return std::max(0.0f, 1.0f - reflectivity - transparency);
}

/// The weights of a surface's two secondary branches.
struct BranchWeights {
    float reflected = 0.0f;  ///< Mirrored: the reflectivity plus the totally reflected share.
    float refracted = 0.0f;  ///< Transmitted through the surface.
};

/// The transmitted share `transparency` refracts in the fraction `refracted_fraction` and is
/// totally reflected in the rest, which the mirrored branch carries beside the reflectivity:
/// 1 for a ray that refracts, 0 past the critical angle, between for a footprint that straddles
/// it.
inline BranchWeights branch_weights(float reflectivity, float transparency,
                                    float refracted_fraction) {
    MRT_DCHECK(refracted_fraction >= 0.0f && refracted_fraction <= 1.0f);
    return {reflectivity + transparency * (1.0f - refracted_fraction),
            transparency * refracted_fraction};
}

/// Whether a branch carrying `share` of a ray whose own contribution to the pixel is `weight` is
/// traced.
inline bool worth_tracing(float weight, float share) {
    return share > 0.0f && weight * share >= kMinimumWeight;
}

/// `local` (what the surface scatters itself) plus its secondary branches, each traced only when
/// worth it: `refracted(w)` and `reflected(w)` return the radiance of their branch traced with
/// path weight w. Refraction is added first, then reflection, in every tracer: float sums taken
/// in another order would change the images' bits.
template <typename Refracted, typename Reflected>
Rgb add_branches(Rgb local, float weight, const BranchWeights& branches, Refracted&& refracted,
                 Reflected&& reflected) {
    if (worth_tracing(weight, branches.refracted)) {
        local += branches.refracted * refracted(weight * branches.refracted);
    }
    if (worth_tracing(weight, branches.reflected)) {
        local += branches.reflected * reflected(weight * branches.reflected);
    }
    return local;
}

/// The side of a surface a direction must leave on.
enum class Side : std::uint8_t {
    Above,  ///< The side the geometric normal points to (reflection).
    Below,  ///< The other side (transmission).
};

/// A direction on the wrong side of the geometric surface (a glossy spread or an interpolated
/// normal sending a reflection into the surface, or a transmission back out) is mirrored about
/// the tangent plane: the energy stays with the branch instead of being lost or leaking.
inline Vec3f fold_to_side(const Vec3f& direction, const Vec3f& geometric_normal, Side side) {
    const float along = direction.dot(geometric_normal);
    if (side == Side::Above ? along > 0.0f : along < 0.0f) {
        return direction;
    }
    return direction - 2.0f * along * geometric_normal;
}

}  // namespace mrt
