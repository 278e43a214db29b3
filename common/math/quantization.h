#pragma once
// Quantization codecs of the point-hierarchy file. Wand & Straßer (2003, §3.2): "all point
// properties are quantized to small integer values (8 bit for material properties and position,
// 16 bit for differential properties)". The tracer decodes these in its innermost loop, so every
// decoder is a few branch-free (or trivially predictable) operations, mostly constexpr, and never
// returns NaN or Inf for any code, not even for codes the encoders never produce.
//
// Every codec states its worst-case error next to it, as a constexpr constant that
// tests/common/math/quantization_test.cpp checks against an independent reference:
//
//   field                      bits   decoded error (worst case)
//   voxel position             3×8    ≤ ½ voxel side per axis (voxel centres exact)
//   node offset (sphere)       3×16   ≤ ½·side/65535 per axis; radius inflated conservatively
//   unit normal (octahedral)   2×16   ≤ 4.35e-5 rad (0.0025°); unit length to 2 ulp
//   normal gradient entry      16     IEEE half: relative ≤ 2⁻¹¹ in [2⁻¹⁴, 65504]
//   tangent orientation        16     ≤ π/65536 rad (+ float rounding) about the normal
//   colour channel (sRGB)      8      ≤ 4.45e-3 linear (near white), ≤ 1.52e-4 below 0.003
//   reflectivity, transparency,
//   roughness                  8      ≤ ½/255
//   Phong exponent (log)       8      relative ≤ 1.81 % over [1, 10000]
//   normal length ℓ (spread)   8      1 − ℓ to ≤ √(1 − ℓ)/255 + 1/(4·255²)
//   index of refraction        8      ≤ 1/255 over [1, 3]
//
// Encoders saturate out-of-range input to the nearest representable value and map NaN to code 0
// (documented per field); they run in the preprocessor, so some (normals, tangent angles) search
// for the best code instead of rounding once.

#include "common/math/math.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <iosfwd>
#include <limits>

namespace mrt {

// ---------------------------------------------------------------------------------------------
// Positions: 8 bits per axis on the k³ voxel grid of an octree node

/// Largest grid resolution k (voxels per cube side) whose voxel index fits in 8 bits.
inline constexpr int kMaxVoxelGridResolution = 256;

/// Worst-case per-axis distance between a point inside the node cube and its decoded voxel
/// centre, in voxel sides (side/k). Add the float rounding of the decode, a few ulps of
/// |origin| + side, for the absolute bound.
inline constexpr float kVoxelPositionMaxError = 0.5f;

/// Index of the voxel holding coordinate x along one axis of the cube [origin, origin + side)
/// split into k voxels (1 ≤ k ≤ 256): ⌊(x − origin)/(side/k)⌋, clamped to [0, k − 1]; NaN → 0.
/// Inverts decode_voxel_coordinate() exactly (encode(decode(i)) == i) as long as a voxel is
/// wider than a few ulps of |origin| + side, true of any octree of fewer than ~20 levels.
constexpr std::uint8_t encode_voxel_coordinate(float x, float origin, float side, int k) {
    const float voxel_side = side / static_cast<float>(k);
    const float t = (x - origin) / voxel_side;
    // Written so that NaN (side 0, x NaN) fails the comparison and lands on 0.
    const float clamped = t >= 0.0f ? std::min(t, static_cast<float>(k - 1)) : 0.0f;
    return static_cast<std::uint8_t>(clamped);
}

/// Centre of voxel i along one axis: origin + (i + ½)·(side/k). The preprocessor places its
/// representative points with this very function (Wand & Straßer §3.2: "a representative point
/// is created in the center of the voxel"), so a stored representative decodes bit-exactly.
constexpr float decode_voxel_coordinate(std::uint8_t i, float origin, float side, int k) {
    const float voxel_side = side / static_cast<float>(k);
    return origin + (static_cast<float>(i) + 0.5f) * voxel_side;
}

/// A position as three 8-bit voxel indices (x, y, z).
using VoxelCode = std::array<std::uint8_t, 3>;

/// The voxel of the node cube [origin, origin + side)³ on a k³ grid that holds p (per axis as
/// encode_voxel_coordinate(); points outside the cube clamp to the boundary voxels).
inline VoxelCode encode_voxel(const Vec3f& p, const Vec3f& origin, float side, int k) {
    return {encode_voxel_coordinate(p.x(), origin.x(), side, k),
            encode_voxel_coordinate(p.y(), origin.y(), side, k),
            encode_voxel_coordinate(p.z(), origin.z(), side, k)};
}

/// Centre of voxel `code` of the node cube, in the cube's (object) space.
inline Vec3f decode_voxel(const VoxelCode& code, const Vec3f& origin, float side, int k) {
    return {decode_voxel_coordinate(code[0], origin.x(), side, k),
            decode_voxel_coordinate(code[1], origin.y(), side, k),
            decode_voxel_coordinate(code[2], origin.z(), side, k)};
}

// ---------------------------------------------------------------------------------------------
// Node offsets: 16 bits per axis, for bounding-sphere centres relative to their node cube

/// Largest 16-bit node-offset code; code c decodes to origin + c·side/65535.
inline constexpr int kNodeOffsetMaxCode = 65535;

/// Worst-case per-axis error of a point inside the cube, in cube sides (plus float rounding).
inline constexpr float kNodeOffsetMaxError = 0.5f / 65535.0f;

/// Nearest of the 65536 evenly spaced offsets origin + c·side/65535 to x (both cube faces are
/// representable); clamped to the cube, NaN → 0.
constexpr std::uint16_t encode_node_offset(float x, float origin, float side) {
    const float t = (x - origin) / side * static_cast<float>(kNodeOffsetMaxCode);
    const float clamped = t >= 0.0f ? std::min(t, static_cast<float>(kNodeOffsetMaxCode)) : 0.0f;
    return static_cast<std::uint16_t>(clamped + 0.5f);
}

constexpr float decode_node_offset(std::uint16_t code, float origin, float side) {
    return origin + static_cast<float>(code) * (side / static_cast<float>(kNodeOffsetMaxCode));
}

/// A point of a node cube as three 16-bit offsets (x, y, z).
using NodeOffsetCode = std::array<std::uint16_t, 3>;

inline NodeOffsetCode encode_node_position(const Vec3f& p, const Vec3f& origin, float side) {
    return {encode_node_offset(p.x(), origin.x(), side),
            encode_node_offset(p.y(), origin.y(), side),
            encode_node_offset(p.z(), origin.z(), side)};
}

inline Vec3f decode_node_position(const NodeOffsetCode& code, const Vec3f& origin, float side) {
    return {decode_node_offset(code[0], origin.x(), side),
            decode_node_offset(code[1], origin.y(), side),
            decode_node_offset(code[2], origin.z(), side)};
}

/// Radius for a bounding sphere whose centre was moved from `centre` to `decoded_centre` by
/// quantization, so that the decoded sphere still contains the original one (the Embree rule:
/// a quantized bound never shrinks what it bounds): radius + |centre − decoded_centre|, rounded
/// upwards by a few ulps to cover the float rounding of this sum and of the tracer's tests.
float conservative_sphere_radius(float radius, const Vec3f& centre, const Vec3f& decoded_centre);

// ---------------------------------------------------------------------------------------------
// Unit normals: octahedral mapping, 16 bits per coordinate

/// Octahedral code (Meyer et al. 2010; Cigolle et al. 2014, "A Survey of Efficient
/// Representations for Independent Unit Vectors"): the unit sphere projected onto the
/// octahedron |x| + |y| + |z| = 1, the lower half folded out onto the square [−1, 1]², and each
/// square coordinate stored as u = 32767 + round(32767·s). The 65535 levels put s = −1, 0, 1
/// on codes 0, 32767, 65534, so the poles, the equator z = 0, the coordinate axes and the
/// octahedron's fold decode exactly; the unused code 65535 decodes like 65534.
struct NormalCode {
    std::uint16_t u = kCentre;  ///< First square coordinate (x side of the octahedron).
    std::uint16_t v = kCentre;  ///< Second square coordinate (y side).

    /// The code of the square's centre s = 0 (with u = v = kCentre: the normal +z).
    static constexpr std::uint16_t kCentre = 32767;

    friend constexpr bool operator==(const NormalCode&, const NormalCode&) = default;
};
static_assert(sizeof(NormalCode) == 4);

/// Largest angle between a unit normal and the decoded normal of its code, in radians. The
/// worst cells are at the octants' centres ±(1, 1, 1)/√3, where the map shears a grid cell of
/// side h = 1/32767 into a rhombus with diagonals √18·h and √6·h; the point of such a rhombus
/// farthest from its corners lies √2·h = 4.316e-5 from three of them. Measured: 4.3143e-5 over
/// 5·10⁷ random and cell-centred directions; tests/common/math/quantization_test.cpp samples 2·10⁶
/// random directions, the poles, equator and edges, and 3.2·10⁶ directions in the octant-centre
/// cells.
inline constexpr float kNormalMaxAngularError = 4.35e-5f;

/// Largest deviation of |decode_normal(code)| from 1 over every code (measured once over all
/// 2³² codes: 1.47e-7, 1.23 ulp of 1; the tests check 2.4·10⁷ codes including every edge).
inline constexpr float kNormalMaxLengthError = 2.0f * std::numeric_limits<float>::epsilon();

/// The code whose decoded normal makes the smallest angle with n (n need not be unit length):
/// the four codes around the projected point are tried, as Cigolle et al.'s "precise" variant
/// does. A zero or non-finite n encodes as +z.
NormalCode encode_normal(const Vec3f& n);

/// Unit normal of a code. The unfolding is done on the integer grid, exactly: the vector before
/// normalisation is (a, b, 32767 − |a| − |b|) with integers |a|, |b| ≤ 32767 (folded for the
/// lower half), whose L1 norm is exactly 32767, so its length is at least 32767/√3 and the
/// normalisation can neither divide by zero nor produce NaN.
inline Vec3f decode_normal(NormalCode code) {
    const int a = std::min<int>(code.u, 2 * NormalCode::kCentre) - NormalCode::kCentre;
    const int b = std::min<int>(code.v, 2 * NormalCode::kCentre) - NormalCode::kCentre;
    const int z = NormalCode::kCentre - std::abs(a) - std::abs(b);
    // Lower half (z < 0): reflect the square's corner triangle back across the diamond edge.
    const int fold = std::max(-z, 0);
    const int x = a >= 0 ? a - fold : a + fold;
    const int y = b >= 0 ? b - fold : b + fold;
    const Vec3f v(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
    return v / v.norm();
}

// ---------------------------------------------------------------------------------------------
// Normal gradients: IEEE half per matrix entry, saturating

/// Largest finite half, the value every larger magnitude (and ±Inf) saturates to.
inline constexpr float kHalfMax = 65504.0f;
/// Smallest normal half; below it halves are subnormal with a fixed absolute step of 2⁻²⁴.
inline constexpr float kHalfMinNormal = 0x1p-14f;
/// Relative error of encode_half() for |x| in [kHalfMinNormal, kHalfMax] (round to nearest
/// even with an 11-bit significand).
inline constexpr float kHalfRelativeError = 0x1p-11f;
/// Absolute error of encode_half() for |x| < kHalfMinNormal (half the subnormal step; below
/// 2⁻²⁵ values flush to ±0).
inline constexpr float kHalfSubnormalAbsoluteError = 0x1p-25f;

/// IEEE 754 binary16 bits of x, rounded to nearest even, with two departures that keep the
/// stored gradients finite: magnitudes that would round to Inf (≥ 65520), and ±Inf, saturate to
/// ±65504; NaN becomes +0.
constexpr std::uint16_t encode_half(float x) {
    const std::uint32_t bits = std::bit_cast<std::uint32_t>(x);
    const std::uint32_t sign = (bits >> 16) & 0x8000u;
    const std::uint32_t magnitude = bits & 0x7fffffffu;
    if (magnitude > 0x7f800000u) {  // NaN
        return 0;
    }
    if (magnitude >= 0x477ff000u) {  // ≥ 65520 = 65504 + half an ulp: rounds to Inf in IEEE
        return static_cast<std::uint16_t>(sign | 0x7bffu);
    }
    if (magnitude < 0x38800000u) {  // < 2⁻¹⁴: a subnormal half, an integer multiple of 2⁻²⁴
        // x·2²⁴ < 1024 is exact; adding 2²³ leaves no fraction bits, so the float addition
        // itself rounds to the nearest integer, ties to even.
        const float scaled = std::bit_cast<float>(magnitude) * 0x1p24f + 0x1p23f;
        return static_cast<std::uint16_t>(sign |
                                          (std::bit_cast<std::uint32_t>(scaled) - 0x4b000000u));
    }
    // Normal: rebias the exponent (127 → 15) and round the 23-bit significand to 10 bits, ties
    // to even; a carry out of the significand correctly bumps the exponent.
    const std::uint32_t odd = (magnitude >> 13) & 1u;
    const std::uint32_t rounded =
        magnitude + 0x0fffu + odd - (static_cast<std::uint32_t>(112) << 23);
    return static_cast<std::uint16_t>(sign | (rounded >> 13));
}

/// The float value of half bits h. Codes encode_half() never produces are read as it would
/// have written them: ±Inf as ±65504, NaN as 0, so no code decodes to a non-finite value.
constexpr float decode_half(std::uint16_t h) {
    std::uint32_t magnitude = h & 0x7fffu;
    if (magnitude >= 0x7c00u) {
        magnitude = magnitude == 0x7c00u ? 0x7bffu : 0u;
    }
    const std::uint32_t sign = static_cast<std::uint32_t>(h & 0x8000u) << 16;
    if (magnitude < 0x0400u) {  // zero or subnormal: exactly magnitude·2⁻²⁴
        const float value = static_cast<float>(magnitude) * 0x1p-24f;
        return sign != 0 ? -value : value;
    }
    return std::bit_cast<float>(sign |
                                ((magnitude << 13) + (static_cast<std::uint32_t>(112) << 23)));
}

/// A 2×2 normal gradient as four halves, column-major: G(0,0), G(1,0), G(0,1), G(1,1).
using GradientCode = std::array<std::uint16_t, 4>;

inline GradientCode encode_gradient(const Mat2f& g) {
    return {encode_half(g(0, 0)), encode_half(g(1, 0)), encode_half(g(0, 1)), encode_half(g(1, 1))};
}

inline Mat2f decode_gradient(const GradientCode& code) {
    Mat2f g;
    g << decode_half(code[0]), decode_half(code[2]), decode_half(code[1]), decode_half(code[3]);
    return g;
}

// ---------------------------------------------------------------------------------------------
// Tangent-frame orientation: one 16-bit angle about the normal

/// The tangent every stored orientation angle is measured from: the first vector of Duff et
/// al.'s branch-free orthonormal basis (2017, "Building an Orthonormal Basis, Revisited"), a
/// deterministic function of the unit normal n, accurate for every n including ±z (its one
/// discontinuity, the sign switch at z = ±0, is harmless because the encoder and the tracer
/// evaluate it on the same decoded normal). With canonical_bitangent(n) = n × t it forms a
/// right-handed frame (t, n × t, n).
inline Vec3f canonical_tangent(const Vec3f& n) {
    Vec3f t;
    Vec3f b;
    orthonormal_basis(n, t, b);
    return t;
}

/// The second canonical tangent, n × canonical_tangent(n) (Duff et al.'s b).
inline Vec3f canonical_bitangent(const Vec3f& n) {
    Vec3f t;
    Vec3f b;
    orthonormal_basis(n, t, b);
    return b;
}

/// Angle step of the orientation code: 2π/65536.
inline constexpr float kTangentAngleStep = 2.0f * kPi / 65536.0f;

/// Largest angle about the normal between a tangent and its decoded tangent: half a step plus
/// the float rounding of sin and cos in the decode.
inline constexpr float kTangentAngleMaxError = 0.5f * kTangentAngleStep + 0x1p-21f;

/// The orientation code of `tangent` about the unit normal `normal`, which must be the decoded
/// normal the tracer will see (the canonical tangent depends on it): the angle from
/// canonical_tangent(normal) to the tangent's projection onto the plane orthogonal to `normal`,
/// counter-clockwise about `normal`, rounded to a multiple of 2π/65536. A tangent with no
/// finite, non-zero projection encodes as 0, which decodes to the canonical tangent exactly.
std::uint16_t encode_tangent_angle(const Vec3f& tangent, const Vec3f& normal);

/// The unit tangent of `code` about the unit normal `normal`: cos θ·t + sin θ·(n × t) with t
/// the canonical tangent. The frame's second tangent is normal × (the result).
inline Vec3f decode_tangent(std::uint16_t code, const Vec3f& normal) {
    Vec3f t;
    Vec3f b;
    orthonormal_basis(normal, t, b);
    if (code == 0) {  // the common case (canonical frames): exact, and no sin/cos
        return t;
    }
    // As a signed angle in (−π, π], which halves the float rounding of the angle itself.
    const float angle = static_cast<float>(static_cast<std::int16_t>(code)) * kTangentAngleStep;
    return std::cos(angle) * t + std::sin(angle) * b;
}

// ---------------------------------------------------------------------------------------------
// Material scalars: 8 bits each

namespace detail {

/// e^x in double precision for constant tables (std::exp is not constexpr in C++20): reduce to
/// r = x − k·ln 2 with |r| ≤ ½ ln 2, sum the Taylor series (relative error ~1e-16), scale by 2^k.
constexpr double constexpr_exp(double x) {
    constexpr double kLn2 = 0.693147180559945309417232121458;
    const int k = static_cast<int>(x / kLn2 + (x >= 0.0 ? 0.5 : -0.5));
    const double r = x - k * kLn2;
    double sum = 1.0;
    double term = 1.0;
    for (int i = 1; i < 24; ++i) {
        term *= r / i;
        sum += term;
    }
    for (int i = 0; i < k; ++i) {
        sum *= 2.0;
    }
    for (int i = 0; i > k; --i) {
        sum *= 0.5;
    }
    return sum;
}

/// ln x for x > 0 in double precision for constant tables: Newton–Halley steps on e^y = x from
/// a first guess, converging cubically (six steps are plenty for x in [1e-4, 1e4]).
constexpr double constexpr_log(double x) {
    double y = (x - 1.0) / (x + 1.0) * 2.0;  // good near 1; the steps below do the rest
    for (int i = 0; i < 40; ++i) {
        const double e = constexpr_exp(y);
        y += 2.0 * (x - e) / (x + e);
    }
    return y;
}

/// The sRGB electro-optical transfer function (IEC 61966-2-1), sRGB value → linear.
constexpr double srgb_to_linear(double s) {
    return s <= 0.04045 ? s / 12.92 : constexpr_exp(2.4 * constexpr_log((s + 0.055) / 1.055));
}

/// An 8-bit code over a strictly increasing table: the 256 decoded values and the 255 decision
/// thresholds between neighbours, so that encoding is a branch-free binary search.
struct Table8 {
    std::array<float, 256> values{};
    std::array<float, 255> thresholds{};
};

/// The smallest float ≥ x, for x ≥ 0 (std::nextafter is not constexpr in C++20).
constexpr float float_at_or_above(double x) {
    const auto f = static_cast<float>(x);
    return static_cast<double>(f) >= x ? f
                                       : std::bit_cast<float>(std::bit_cast<std::uint32_t>(f) + 1u);
}

/// A table of the given (increasing, positive) values whose thresholds are the exact midpoints
/// of neighbouring float values, rounded up to a float: for a float x, x ≥ threshold exactly
/// when x is at least as close to the upper value, so the encoder returns the nearest code
/// (ties upwards) with no rounding slack.
constexpr Table8 make_nearest_table(const std::array<double, 256>& values) {
    Table8 table;
    for (int c = 0; c < 256; ++c) {
        table.values[c] = static_cast<float>(values[c]);
    }
    for (int c = 0; c < 255; ++c) {
        const double mid = 0.5 * (static_cast<double>(table.values[c]) +
                                  static_cast<double>(table.values[c + 1]));  // exact
        table.thresholds[c] = float_at_or_above(mid);
    }
    return table;
}

/// Code c decodes to the linear value of sRGB value c/255.
constexpr Table8 make_srgb8_table() {
    std::array<double, 256> linear{};
    for (int c = 0; c < 256; ++c) {
        linear[c] = srgb_to_linear(c / 255.0);
    }
    return make_nearest_table(linear);
}

/// Code c decodes to 10000^(c/255), with exact ends.
constexpr Table8 make_phong8_table() {
    std::array<double, 256> exponent{};
    const double step = constexpr_log(10000.0) / 255.0;
    for (int c = 0; c < 256; ++c) {
        exponent[c] = constexpr_exp(c * step);
    }
    exponent[0] = 1.0;
    exponent[255] = 10000.0;
    return make_nearest_table(exponent);
}

/// The number of thresholds ≤ x, by an 8-step binary search: the code of the nearest value,
/// ties upwards; NaN fails every comparison and gives 0.
constexpr std::uint8_t encode_by_table(float x, const Table8& table) {
    int code = 0;
    for (int step = 128; step >= 1; step /= 2) {
        code += x >= table.thresholds[code + step - 1] ? step : 0;
    }
    return static_cast<std::uint8_t>(code);
}

}  // namespace detail

/// Decoded linear value of each 8-bit sRGB code.
inline constexpr detail::Table8 kSrgb8Table = detail::make_srgb8_table();
/// Decoded value of each 8-bit Phong-exponent code.
inline constexpr detail::Table8 kPhong8Table = detail::make_phong8_table();

/// Worst-case error of encode_unit8 over [0, 1]: half a step (plus the float rounding of c/255,
/// below 1e-7).
inline constexpr float kUnit8MaxError = 0.5f / 255.0f;

/// A value in [0, 1] (reflectivity, transparency, roughness) as round(255·x); out-of-range
/// input saturates, NaN → 0. 0 and 1 are exact.
constexpr std::uint8_t encode_unit8(float x) {
    const float clamped = x >= 0.0f ? std::min(x, 1.0f) : 0.0f;
    return static_cast<std::uint8_t>(clamped * 255.0f + 0.5f);
}

constexpr float decode_unit8(std::uint8_t code) {
    return static_cast<float>(code) / 255.0f;
}

/// Coverage (the area a point stands for over its voxel face, preprocess/octree/point_octree.h) in
/// [0, 2] as encode_unit8(c/2): a surface folded into one voxel counts up to twice; more
/// saturates. Error at most 2·kUnit8MaxError.
/// The length ℓ of the average of a point's unit normals (Toksvig's measure of their spread), as
/// 255·√(1 − ℓ): a Phong lobe of exponent p is widened to ℓ·p/(ℓ + p·(1 − ℓ)), so what matters is
/// 1 − ℓ near 0, where a linear code's first step (1/255) would already halve an exponent of
/// 300. Here the step at 1 − ℓ = s is 2·√s/255: exponent 300 moves by under 1 % per step near 1.
inline std::uint8_t encode_normal_length8(float length) {
    const float spread = 1.0f - (length < 0.0f ? 0.0f : length > 1.0f ? 1.0f : length);
    return encode_unit8(std::sqrt(spread));
}

constexpr float decode_normal_length8(std::uint8_t code) {
    const float root = decode_unit8(code);
    return 1.0f - root * root;
}

/// Worst-case error of decode_normal_length8(encode_normal_length8(ℓ)) for ℓ in [0, 1]: half a
/// step of √(1 − ℓ), squared out (plus float rounding).
inline float normal_length8_max_error(float length) {
    return std::sqrt(std::max(0.0f, 1.0f - length)) / 255.0f + 0.25f / (255.0f * 255.0f) + 1e-6f;
}

constexpr std::uint8_t encode_coverage8(float coverage) {
    return encode_unit8(0.5f * coverage);
}

constexpr float decode_coverage8(std::uint8_t code) {
    return 2.0f * decode_unit8(code);
}

/// Worst-case error of encode_offset8 over [−1, 1]: half a step of 1/127.
inline constexpr float kOffset8MaxError = 0.5f / 127.0f;

/// A signed offset in [−1, 1] voxel sides (a point's surface along its normal, which lies
/// within the half diagonal √3/2 of the voxel centre) as round(127·x); out-of-range input
/// saturates, NaN → 0. 0 and ±1 are exact.
constexpr std::int8_t encode_offset8(float x) {
    const float clamped = x >= -1.0f ? std::min(x, 1.0f) : (x < -1.0f ? -1.0f : 0.0f);
    const float scaled = clamped * 127.0f;
    return static_cast<std::int8_t>(scaled >= 0.0f ? scaled + 0.5f : scaled - 0.5f);
}

constexpr float decode_offset8(std::int8_t code) {
    return static_cast<float>(code) / 127.0f;
}

/// Worst-case error of a linear colour channel in [0, 1], in linear units: half the largest gap
/// between neighbouring decoded values, which is the top one, (1 − decode_srgb8(254))/2 =
/// 4.4490e-3.
inline constexpr float kSrgb8MaxLinearError = 4.45e-3f;
/// Dark tones, linear values up to kSrgb8DarkLimit (codes 0–10, the sRGB curve's linear
/// segment), have the error ½/(255·12.92) = 1.5176e-4 at most: 29 times finer.
inline constexpr float kSrgb8DarkLimit = 0.003f;
inline constexpr float kSrgb8MaxDarkLinearError = 1.52e-4f;

/// A linear colour channel in [0, 1] as the 8-bit sRGB code whose decoded linear value is
/// nearest (the code is the sRGB transfer curve's value ×255, so dark tones get the finer
/// steps the eye needs). Out-of-range input saturates to 0 or 1; NaN → 0 (black).
constexpr std::uint8_t encode_srgb8(float linear) {
    return detail::encode_by_table(linear, kSrgb8Table);
}

/// Linear value of an 8-bit sRGB code; 0 → 0 and 255 → 1 exactly.
constexpr float decode_srgb8(std::uint8_t code) {
    return kSrgb8Table.values[code];
}

/// Linear RGB colour as three sRGB codes (r, g, b).
using Rgb8Code = std::array<std::uint8_t, 3>;

inline Rgb8Code encode_rgb8(const Rgb& c) {
    return {encode_srgb8(c[0]), encode_srgb8(c[1]), encode_srgb8(c[2])};
}

inline Rgb decode_rgb8(const Rgb8Code& code) {
    return {decode_srgb8(code[0]), decode_srgb8(code[1]), decode_srgb8(code[2])};
}

/// Range of the Phong exponent code.
inline constexpr float kPhongExponentMin = 1.0f;
inline constexpr float kPhongExponentMax = 10000.0f;
/// Worst-case error of an exponent e in [1, 10000] relative to e: with neighbours a < b = ρ·a,
/// ρ = 10000^(1/255), the nearest code errs by at most (b − a)/(b + a) = (ρ − 1)/(ρ + 1) =
/// 1.80575e-2, at the midpoint.
inline constexpr float kPhong8MaxRelativeError = 0.01806f;

/// A Phong exponent in [1, 10000], log-encoded (code c ↔ 10000^(c/255), a constant ratio of
/// ρ = 1.0368 between neighbours, so the relative step is the same for glossy and diffuse
/// exponents) to the nearest code, which is also the one of least relative error. Exponents
/// below 1 (and NaN) give code 0 = exponent 1; above 10000 saturate.
constexpr std::uint8_t encode_phong8(float exponent) {
    return detail::encode_by_table(exponent, kPhong8Table);
}

/// Exponent of a code; 0 → 1 and 255 → 10000 exactly.
constexpr float decode_phong8(std::uint8_t code) {
    return kPhong8Table.values[code];
}

/// Range of the index-of-refraction code.
inline constexpr float kIorMin = 1.0f;
inline constexpr float kIorMax = 3.0f;
/// Worst-case error of an index of refraction in [1, 3]: half a step of 2/255 (plus float
/// rounding, below 1e-6).
inline constexpr float kIor8MaxError = 1.0f / 255.0f;

/// An index of refraction in [1, 3] as round(255·(η − 1)/2); out-of-range input saturates,
/// NaN → 0 (η = 1, no refraction). 1 and 3 are exact.
constexpr std::uint8_t encode_ior8(float ior) {
    return encode_unit8((ior - kIorMin) * 0.5f);
}

constexpr float decode_ior8(std::uint8_t code) {
    return kIorMin + static_cast<float>(code) * (kIorMax - kIorMin) / 255.0f;
}

std::ostream& operator<<(std::ostream& os, const NormalCode& code);

}  // namespace mrt
