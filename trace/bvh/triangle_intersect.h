#pragma once
// The two per-ray kernels of BVH traversal, each with its per-ray constants computed once:
//  - the watertight ray/triangle test of Woop, Benthin & Wald 2013, "Watertight Ray/Triangle
//    Intersection" (JCGT 2(1)): vertices are translated to the ray origin, permuted so the
//    dominant direction axis becomes z, and sheared so the ray becomes the +z axis; the 2D edge
//    functions are then evaluated on per-vertex values that do not depend on the triangle, so the
//    two triangles sharing an edge compute exactly negated edge functions and a ray can never
//    slip through a shared edge or vertex;
//  - a conservative slab test (Kay & Kajiya 1986) whose far distance is widened by 1 + 2γ₃ as
//    in Ize 2013, "Robust BVH Ray Traversal" (JCGT 2(2)), so rounding never makes a box miss.

#include "common/math/math.h"
#include "common/math/ray.h"

#include <cmath>
#include <cstdint>
#include <limits>

namespace mrt {

/// Ray constants of the watertight test: dominant axis kz, the two others (kx, ky) ordered to
/// keep the winding, and the shear that maps the direction onto +z.
struct WatertightRay {
    int kx = 0, ky = 1, kz = 2;
    float origin[3] = {0.0f, 0.0f, 0.0f};  ///< Ray origin, indexed by world axis.
    float sx = 0.0f, sy = 0.0f, sz = 1.0f;

    WatertightRay() = default;
    explicit WatertightRay(const Ray& ray) {
        const Vec3f& d = ray.direction;
        const Vec3f a = d.cwiseAbs();
        kz = a.x() >= a.y() ? (a.x() >= a.z() ? 0 : 2) : (a.y() >= a.z() ? 1 : 2);
        kx = kz == 2 ? 0 : kz + 1;
        ky = kx == 2 ? 0 : kx + 1;
        // A negative dominant component mirrors the projected triangle; swapping x and y undoes
        // the mirror, so front faces keep positive edge functions.
        if (d[kz] < 0.0f) {
            const int swap = kx;
            kx = ky;
            ky = swap;
        }
        sx = d[kx] / d[kz];
        sy = d[ky] / d[kz];
        sz = 1.0f / d[kz];
        origin[0] = ray.origin.x();
        origin[1] = ray.origin.y();
        origin[2] = ray.origin.z();
    }
};

/// Where a ray meets a triangle: ray parameter and barycentric weights of vertices 1 and 2.
struct TriangleIntersection {
    float t = kInfinity;
    float b1 = 0.0f;
    float b2 = 0.0f;
};

/// True when the edge functions have strictly opposite signs (the ray passes outside).
/// Ties (zeros) are not decided here: they go to the double-precision re-evaluation.
inline bool edge_signs_differ(float u, float v, float w) {
    return (u < 0.0f || v < 0.0f || w < 0.0f) && (u > 0.0f || v > 0.0f || w > 0.0f);
}

/// Re-evaluates the three 2D edge functions of the sheared vertices in double precision, where
/// the products are exact, so an edge function is zero only when the ray truly passes through
/// the edge. Needed only when one float edge function came out zero: a nonzero float result
/// already has the exact sign (rounding is monotonic), so this never turns a miss into a hit
/// by itself; it just decides the ties consistently for all triangles sharing the edge.
inline void edge_functions_double(float ax, float ay, float bx, float by, float cx, float cy,
                                  float& u, float& v, float& w) {
    const double u_exact = static_cast<double>(cx) * by - static_cast<double>(cy) * bx;
    const double v_exact = static_cast<double>(ax) * cy - static_cast<double>(ay) * cx;
    const double w_exact = static_cast<double>(bx) * ay - static_cast<double>(by) * ax;
    u = static_cast<float>(u_exact);
    v = static_cast<float>(v_exact);
    w = static_cast<float>(w_exact);
}

/// Watertight ray/triangle test (both faces). On a hit with t > 0 writes `out` and returns
/// true; the caller checks t against its interval. Every operation is IEEE single precision in a
/// fixed order, so the SIMD leaf kernel of TriangleBvh reproduces the result bit for bit.
inline bool intersect_triangle(const WatertightRay& r, const Vec3f& p0, const Vec3f& p1,
                               const Vec3f& p2, TriangleIntersection& out) {
    const int kx = r.kx, ky = r.ky, kz = r.kz;
    // Vertices relative to the origin, in the permuted axes.
    const float a_x = p0[kx] - r.origin[kx], a_y = p0[ky] - r.origin[ky];
    const float a_z = p0[kz] - r.origin[kz];
    const float b_x = p1[kx] - r.origin[kx], b_y = p1[ky] - r.origin[ky];
    const float b_z = p1[kz] - r.origin[kz];
    const float c_x = p2[kx] - r.origin[kx], c_y = p2[ky] - r.origin[ky];
    const float c_z = p2[kz] - r.origin[kz];
    // Shear so the ray is the z axis.
    const float ax = a_x - r.sx * a_z, ay = a_y - r.sy * a_z;
    const float bx = b_x - r.sx * b_z, by = b_y - r.sy * b_z;
    const float cx = c_x - r.sx * c_z, cy = c_y - r.sy * c_z;
    // Scaled barycentrics: edge functions of the 2D triangle at the origin.
    float u = cx * by - cy * bx;
    float v = ax * cy - ay * cx;
    float w = bx * ay - by * ax;
    if (edge_signs_differ(u, v, w)) {
        return false;
    }
    if (u == 0.0f || v == 0.0f || w == 0.0f) {
        edge_functions_double(ax, ay, bx, by, cx, cy, u, v, w);
        if (edge_signs_differ(u, v, w)) {
            return false;
        }
    }
    const float det = u + v + w;
    if (det == 0.0f) {
        return false;
    }
    const float az = r.sz * a_z, bz = r.sz * b_z, cz = r.sz * c_z;
    const float t_scaled = u * az + v * bz + w * cz;
    const float t = t_scaled / det;
    if (!(t > 0.0f)) {
        return false;
    }
    out.t = t;
    out.b1 = v / det;
    out.b2 = w / det;
    return true;
}

/// Widening of a slab test's far distance: each plane distance (b − o)·(1/d) carries three
/// roundings (subtraction, reciprocal, product), so near and far are each within a factor
/// (1 ± γ₃) of the truth and far·(1 + 2γ₃) ≥ near whenever the true interval is non-empty
/// (Ize 2013). Four ulps of 1 exceed 2γ₃ = 6u/(1−3u) plus the rounding of the product itself.
inline constexpr float kSlabFarScale = 1.0f + 4.0f * std::numeric_limits<float>::epsilon();

/// Ray constants of the slab test. Zero direction components (of either sign) and components
/// whose reciprocal overflows get +inf: the plane distances are then ±inf, or NaN when the
/// origin lies exactly on the plane, and the min/max ordering of box_interval() discards those
/// NaNs, so a ray in a box's face plane still enters the box.
struct SlabRay {
    float origin[3] = {0.0f, 0.0f, 0.0f};
    float inv_dir[3] = {0.0f, 0.0f, 0.0f};

    SlabRay() = default;
    explicit SlabRay(const Ray& ray) {
        for (int a = 0; a < 3; ++a) {
            origin[a] = ray.origin[a];
            const float inv = 1.0f / ray.direction[a];
            inv_dir[a] = std::isfinite(inv) ? inv : kInfinity;
        }
    }
};

/// NaN-discarding max/min: the result is `acc` when `x` is NaN (the x86 MAXSS/MINSS rule).
inline float max_keep(float x, float acc) {
    return x > acc ? x : acc;
}
inline float min_keep(float x, float acc) {
    return x < acc ? x : acc;
}

/// Slab test of the box [lower, upper] against the ray interval [t_near, t_far]: returns true
/// and narrows the interval to the box when they overlap (conservatively, see kSlabFarScale).
inline bool box_interval(const SlabRay& r, const float lower[3], const float upper[3],
                         float& t_near, float& t_far) {
    float near = t_near;
    float far = t_far;
    for (int a = 0; a < 3; ++a) {
        const float t0 = (lower[a] - r.origin[a]) * r.inv_dir[a];
        const float t1 = (upper[a] - r.origin[a]) * r.inv_dir[a];
        // With inv_dir = +inf: t0 is NaN only for an origin on the lower plane (then t1 is +inf
        // or NaN) and t1 only for one on the upper plane (t0 then −inf or NaN). Taking the NaN
        // into the near of the first case and the far of the second drops exactly the
        // constraints a ray lying in the face plane does not have.
        const float slab_near = t1 < t0 ? t1 : t0;
        const float slab_far = t0 > t1 ? t0 : t1;
        near = max_keep(slab_near, near);
        far = min_keep(slab_far, far);
    }
    far *= kSlabFarScale;
    if (!(near <= far)) {
        return false;
    }
    t_near = near;
    t_far = far;
    return true;
}

}  // namespace mrt
