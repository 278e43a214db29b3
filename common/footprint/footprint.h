#pragma once
// The one footprint model of the project (DESIGN.md): Igehy's ray differentials (1999) — how a
// ray's origin and unit direction change from one pixel to the next in x and y — propagated
// exactly through transfer, reflection and refraction, and read as Wand & Straßer's linear
// cone fp(t) = startDev + t·incrDev, the 2×2 matrix that maps a pixel offset to the offset on
// the plane orthogonal to the ray at distance t (their §4.1). Texture filtering, point level of
// detail and the soft effects all read this type.
//
// Conventions: directions are unit vectors and their differentials are those of the unit
// vector; equation numbers are Igehy's. Every operation returns finite values: where a
// derivative does not exist (a ray parallel to the surface, total internal reflection at the
// critical angle) the differentials are clamped, never NaN.

#include "common/math/math.h"

namespace mrt {

/// Derivatives of a ray with respect to the image coordinates x and y (per pixel).
struct RayDifferential {
    Vec3f dp_dx = Vec3f::Zero();  ///< ∂P/∂x of the origin.
    Vec3f dp_dy = Vec3f::Zero();
    Vec3f dd_dx = Vec3f::Zero();  ///< ∂D/∂x of the unit direction.
    Vec3f dd_dy = Vec3f::Zero();

    /// Derivative of the unit vector d/|d| given the derivative `dv` of the vector d (Igehy
    /// eq. 8's normalisation): (dv·(d·d) − d·(d·dv)) / |d|³.
    static Vec3f unit_derivative(const Vec3f& d, const Vec3f& dv);

    /// Pinhole camera (eq. 8): rays from one point along d = view + x·step_x + y·step_y.
    static RayDifferential pinhole(const Vec3f& unnormalised_direction, const Vec3f& step_x,
                                   const Vec3f& step_y);

    /// Thin lens: offset rays leave the same lens point and aim at their own point of the plane
    /// in focus, focal_distance·(view + x·step_x + y·step_y) from the lens centre; in focus the
    /// footprint is the pixel's. The aperture's own cone (zero in focus, never letting the
    /// footprint fall below the pixel cone: Wand) is the cone tracer's to add.
    static RayDifferential thin_lens(const Vec3f& lens_to_focus, const Vec3f& step_x,
                                     const Vec3f& step_y, float focal_distance);

    /// Transfer along the unit direction d to the plane with normal n at parameter t (eqs. 10,
    /// 12): the differentials of the hit point, direction unchanged.
    RayDifferential transfer(const Vec3f& d, float t, const Vec3f& n) const;

    /// Mirror reflection of the unit direction d about the unit shading normal n, whose
    /// derivatives are dn_dx, dn_dy (eqs. 14, 15). Call on the transferred differential.
    RayDifferential reflect(const Vec3f& d, const Vec3f& n, const Vec3f& dn_dx,
                            const Vec3f& dn_dy) const;

    /// Refraction of the unit direction d at the unit shading normal n facing against d
    /// (n·d < 0), eta = n_incident / n_transmitted (eqs. 16–19). The caller has checked that
    /// the ray is not totally reflected; at the critical angle the derivative of μ is clamped.
    RayDifferential refract(const Vec3f& d, const Vec3f& n, const Vec3f& dn_dx, const Vec3f& dn_dy,
                            float eta) const;

    /// Through an affine map with linear part `linear` (instances): points and directions
    /// map by the derivative of the transform; the unit direction d (before the map) is
    /// renormalised.
    RayDifferential transformed(const Mat3f& linear, const Vec3f& d) const;

    /// Differentials whose squared length exceeds this are runaway (many bounces through
    /// curved glass) and are scaled back to it.
    static constexpr float kMaxSquaredLength = 1e16f;

    bool finite() const;

  private:
    /// The common form of reflection and refraction, D' = η·D − μ·N with dμ = dmu_factor ·
    /// d(D·N): dD' = η·dD − (μ·dN + dμ·N), origins unchanged.
    RayDifferential redirected(const Vec3f& d, const Vec3f& n, const Vec3f& dn_dx,
                               const Vec3f& dn_dy, float eta, float mu, float dmu_factor) const;
};

/// Derivatives of the unit shading normal and of the texture coordinates at a hit, from the
/// surface's own parameterisation.
struct SurfaceDifferential {
    Vec3f dn_dx = Vec3f::Zero();
    Vec3f dn_dy = Vec3f::Zero();
    Vec2f duv_dx = Vec2f::Zero();
    Vec2f duv_dy = Vec2f::Zero();
    /// Texture-space length per unit of surface length, √(uv area / area) of the triangle:
    /// turns an isotropic world-space footprint into texture space.
    float uv_per_length = 0.0f;
};

/// The derivative of the unit vector n/|n| for a derivative dn of the unnormalised n (Igehy's
/// box in §3.3): (dn·(n·n) − n·(n·dn)) / |n|³.
inline Vec3f normalised_derivative(const Vec3f& n, const Vec3f& dn) {
    return RayDifferential::unit_derivative(n, dn);
}

/// Which side of a surface a ray meets.
enum class Facing : std::uint8_t {
    Front,  ///< The side the interpolated normal points to.
    Back,
};

/// Surface differential of a triangle with world-space vertices p[3] (only their differences
/// are read, so any common translation may be left out — better so far from the origin),
/// unnormalised vertex
/// normals n[3] (world space) and uvs uv[3], for a hit at barycentric (b1, b2) whose position
/// differentials are dp_dx, dp_dy: barycentric coordinates as linear functions of position
/// (the planes of §3.3), so dN and dT are exact for the interpolation. Seen from the back,
/// the normal derivatives are negated with the normal. A degenerate triangle yields zero
/// derivatives.
SurfaceDifferential triangle_differential(const Vec3f p[3], const Vec3f n[3], const Vec2f uv[3],
                                          float b1, float b2, const Vec3f& dp_dx,
                                          const Vec3f& dp_dy, Facing facing);

/// Eigen-decomposition of the symmetric 2×2 matrix [[a, b], [b, c]], stable in closed form:
/// the larger eigenvalue from the sum, the smaller from the determinant, the axis from atan2.
struct SymmetricEigen2 {
    float major = 0.0f;  ///< Larger eigenvalue.
    float minor = 0.0f;  ///< Smaller eigenvalue.
    Vec2f major_axis{1.0f, 0.0f};
    Vec2f minor_axis{0.0f, 1.0f};
};
SymmetricEigen2 symmetric_eigen2(float a, float b, float c);

/// ‖M‖₂, the largest singular value of a 2×2 matrix: the square root of the larger eigenvalue
/// of MᵀM, in closed form (how far M can stretch a unit vector).
float largest_singular_value(const Mat2f& m);

/// The inverse of a 2×2 footprint matrix F (ray u/v offsets per pixel offset) and |det F|, the
/// area of F's unit-disc ellipse over π (ray u/v units²). The determinant is an FMA-compensated
/// difference of products, so nearly collinear columns do not cancel it to a wrong sign or size.
struct FootprintInverse {
    /// F⁻¹: an offset in the ray's u/v plane → footprint coordinates, in which the footprint's
    /// Gaussian exp(−|F⁻¹x|²) (Wand eq. 2) is the unit Gaussian. Zero when F is singular.
    Mat2f inverse = Mat2f::Zero();
    /// |det F|; 0 when F is singular or its inverse would not be finite.
    float abs_det = 0.0f;
};

/// Wand & Straßer's cone of a ray: the footprint at distance t along the unit direction is
/// F(t) = start_dev + t·incr_dev, mapping a pixel offset (dx, dy) to an offset in the plane
/// orthogonal to the ray, in the basis (u, v) of that plane.
struct FootprintCone {
    Vec3f u = Vec3f::UnitX();
    Vec3f v = Vec3f::UnitY();
    Mat2f start_dev = Mat2f::Zero();
    Mat2f incr_dev = Mat2f::Zero();
    /// A second linear cone B(t) = blur_start + t·blur_incr on the same axis whose Gaussian is
    /// convolved with the first (Wand §4.2: "adding the squared footprint matrices"): the
    /// light's ellipse of a shadow cone, the radial growth of a rough reflection, the lens
    /// aperture of depth of field. Zero (`blurred` false) for a plain cone.
    Mat2f blur_start = Mat2f::Zero();
    Mat2f blur_incr = Mat2f::Zero();
    bool blurred = false;

    /// Projects a ray's differentials onto the plane orthogonal to its unit direction d.
    static FootprintCone from_differential(const Vec3f& d, const RayDifferential& rd);

    /// The basis (u, v) as the columns of a 3×2 matrix: basis()·f gives the world vectors of
    /// a footprint's columns, basis()ᵀ·[x y] the footprint of two vectors (their components
    /// in the plane orthogonal to the ray: along the ray they move the footprint, to first
    /// order, without changing its section).
    Mat32f basis() const {
        Mat32f b;
        b.col(0) = u;
        b.col(1) = v;
        return b;
    }
    /// The footprint in this cone's frame of the two vectors x and y: basis()ᵀ·[x y].
    Mat2f project(const Vec3f& x, const Vec3f& y) const {
        Mat2f f;
        f << u.dot(x), u.dot(y), v.dot(x), v.dot(y);
        return f;
    }

    /// The pixel footprint F(t) = start_dev + t·incr_dev alone, without the blur.
    Mat2f pixel_at(float t) const { return start_dev + t * incr_dev; }
    /// The footprint at t: F(t), or for a blurred cone the symmetric G with
    /// G·Gᵀ = F(t)·F(t)ᵀ + B(t)·B(t)ᵀ (only G·Gᵀ is meaningful, as for clamp_anisotropy).
    Mat2f at(float t) const {
        const Mat2f f = pixel_at(t);
        if (!blurred) {
            return f;
        }
        return convolved(f, blur_start + t * blur_incr);
    }

    /// The footprint's growth along the ray, d at(t)/dt: incr_dev, or for a blurred cone the
    /// derivative of the symmetric root G(t) of F·Fᵀ + B·Bᵀ, in closed form (the derivative of
    /// convolved's Cayley–Hamilton root). The directional differentials of the footprint at t.
    Mat2f growth_at(float t) const;

    /// The footprint at t and its growth there, at(t) and growth_at(t), from one decomposition
    /// of the blurred footprint instead of two (the cone shader needs both at every fragment).
    struct Local {
        Mat2f footprint;
        Mat2f growth;
    };
    Local local_at(float t) const;

    /// Adds the cone B(t) = start + t·incr to the blur (squared matrices add, so blurs
    /// accumulate: a rough reflection of a blurred ray stays blurred).
    void add_blur(const Mat2f& start, const Mat2f& incr);

    /// The symmetric square root of F·Fᵀ + B·Bᵀ, in closed form: the Gaussian of F convolved
    /// with the Gaussian of B.
    static Mat2f convolved(const Mat2f& f, const Mat2f& b);

    /// Axes of the footprint ellipse at t (the image of the unit pixel disc): the eigen-
    /// decomposition of F·Fᵀ; diameters are 2·√eigenvalue.
    SymmetricEigen2 ellipse(float t) const;
    /// The same for any footprint matrix F (ray u/v units per pixel).
    static SymmetricEigen2 ellipse_of(const Mat2f& footprint);
    float max_diameter(float t) const;
    float min_diameter(float t) const;

    /// Wand §5.1: the minor axis grown so that major/minor ≤ max_anisotropy, keeping the
    /// major axis: returns F' with the same major axis and a wider minor one.
    static Mat2f clamp_anisotropy(const Mat2f& footprint, float max_anisotropy);
    /// The same, also giving the clamped footprint's ellipse (one decomposition for both).
    static Mat2f clamp_anisotropy(const Mat2f& footprint, float max_anisotropy,
                                  SymmetricEigen2& clamped_ellipse);
    /// The same with the footprint's decomposition (ellipse_of) already known: `ellipse` holds
    /// it on entry and the clamped one on return.
    static Mat2f clamp_decomposed(const Mat2f& footprint, float max_anisotropy,
                                  SymmetricEigen2& ellipse);

    /// The footprint convolved with the isotropic Gaussian exp(−|x|²/radius²) (radius in ray
    /// u/v units): Gaussians convolve by adding their squared matrices (Wand §4.2, after
    /// Zwicker et al.'s EWA resampling filter), so the result G has G·Gᵀ = F·Fᵀ + radius²·I.
    /// G is the symmetric square root of that sum, in closed form; as with clamp_anisotropy
    /// only G·Gᵀ is meaningful. A non-zero radius makes G invertible whatever F is.
    static Mat2f widened(const Mat2f& footprint, float radius);

    /// F⁻¹ and |det F| (see FootprintInverse); all zero for a singular or non-finite F.
    static FootprintInverse inverse(const Mat2f& footprint);
};

}  // namespace mrt
