// The hierarchy file's quantization codecs against independent references — double-precision
// formulas, Eigen::half's IEEE conversion, std::pow and std::exp: every stated error bound,
// exact round trips where promised, and finite decodes for every code (exhaustive for 8-bit and
// 16-bit codes, dense for the 32-bit normal codes).

#include "common/math/quantization.h"

#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <iostream>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

namespace mrt {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

using testing::angle_between;
using testing::random_direction;

/// Units in the last place of a float of magnitude |x|.
double ulp(double x) {
    const float f = static_cast<float>(std::abs(x));
    return static_cast<double>(std::nextafter(f, kInfinity) - f);
}

// The codecs are usable in constant expressions.
static_assert(decode_half(encode_half(1.0f)) == 1.0f);
static_assert(decode_half(encode_half(kInfinity)) == kHalfMax);
static_assert(encode_voxel_coordinate(decode_voxel_coordinate(200, -1.0f, 3.0f, 256), -1.0f, 3.0f,
                                      256) == 200);
static_assert(decode_srgb8(0) == 0.0f && decode_srgb8(255) == 1.0f);
static_assert(decode_phong8(0) == 1.0f && decode_phong8(255) == 10000.0f);
static_assert(decode_unit8(255) == 1.0f && decode_ior8(255) == 3.0f);

// ---------------------------------------------------------------------------------------------
// Voxel positions

struct Cube {
    float origin;
    float side;
};

const Cube kCubes[] = {{0.0f, 1.0f},  {-3.7f, 0.37f}, {1000.5f, 12.25f},
                       {-1e3f, 2e3f}, {1e-3f, 1e-4f}, {-7.0f, 3.0f}};

TEST(VoxelPosition, CentresDecodeToTheVoxelCentreAndRoundTripExactly) {
    for (const int k : {1, 2, 3, 7, 64, 255, 256}) {
        for (const Cube& cube : kCubes) {
            const double voxel = static_cast<double>(cube.side) / k;
            const double slack = 2.0 * ulp(std::abs(cube.origin) + cube.side);
            for (int i = 0; i < k; ++i) {
                const auto code = static_cast<std::uint8_t>(i);
                const float centre = decode_voxel_coordinate(code, cube.origin, cube.side, k);
                const double reference = cube.origin + (i + 0.5) * voxel;
                ASSERT_NEAR(centre, reference, slack) << "k " << k << " i " << i;
                // Strictly inside its voxel, and encoded back to it.
                ASSERT_GT(centre, cube.origin + i * voxel);
                ASSERT_LT(centre, cube.origin + (i + 1) * voxel);
                ASSERT_EQ(encode_voxel_coordinate(centre, cube.origin, cube.side, k), code)
                    << "k " << k << " origin " << cube.origin << " side " << cube.side;
            }
        }
    }
}

TEST(VoxelPosition, ErrorWithinHalfAVoxelInsideTheCube) {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (const int k : {1, 3, 7, 64, 256}) {
        for (const Cube& cube : kCubes) {
            const double bound = static_cast<double>(kVoxelPositionMaxError) * cube.side / k +
                                 4.0 * ulp(std::abs(cube.origin) + cube.side);
            for (int n = 0; n < 20000; ++n) {
                const auto x = static_cast<float>(cube.origin + unit(rng) * cube.side);
                const std::uint8_t code = encode_voxel_coordinate(x, cube.origin, cube.side, k);
                ASSERT_LT(code, k);
                ASSERT_LE(std::abs(decode_voxel_coordinate(code, cube.origin, cube.side, k) - x),
                          bound);
            }
        }
    }
}

TEST(VoxelPosition, OutsideTheCubeClampsAndNanGoesToZero) {
    EXPECT_EQ(encode_voxel_coordinate(-0.5f, 0.0f, 1.0f, 64), 0);
    EXPECT_EQ(encode_voxel_coordinate(1.0f, 0.0f, 1.0f, 64), 63);
    EXPECT_EQ(encode_voxel_coordinate(7.0f, 0.0f, 1.0f, 256), 255);
    EXPECT_EQ(encode_voxel_coordinate(kInfinity, 0.0f, 1.0f, 256), 255);
    EXPECT_EQ(encode_voxel_coordinate(-kInfinity, 0.0f, 1.0f, 256), 0);
    EXPECT_EQ(encode_voxel_coordinate(kNaN, 0.0f, 1.0f, 256), 0);
    EXPECT_EQ(encode_voxel_coordinate(0.5f, 0.0f, 0.0f, 256), 255);  // zero side: +Inf
    EXPECT_EQ(encode_voxel_coordinate(0.0f, 0.0f, 0.0f, 256), 0);    // 0/0
}

TEST(VoxelPosition, Vec3CodesAreThePerAxisCodes) {
    const Vec3f origin(-1.0f, 2.0f, 0.5f);
    const Vec3f p(-0.2f, 2.9f, 0.51f);
    const VoxelCode code = encode_voxel(p, origin, 1.0f, 10);
    EXPECT_EQ(code, (VoxelCode{8, 9, 0}));
    const Vec3f centre = decode_voxel(code, origin, 1.0f, 10);
    EXPECT_FLOAT_EQ(centre.x(), -0.15f);
    EXPECT_FLOAT_EQ(centre.y(), 2.95f);
    EXPECT_FLOAT_EQ(centre.z(), 0.55f);
}

// ---------------------------------------------------------------------------------------------
// Node offsets and conservative bounding spheres

TEST(NodeOffset, EveryCodeRoundTripsAndBothFacesAreExact) {
    for (const Cube& cube : kCubes) {
        EXPECT_EQ(decode_node_offset(0, cube.origin, cube.side), cube.origin);
        EXPECT_NEAR(decode_node_offset(65535, cube.origin, cube.side),
                    static_cast<double>(cube.origin) + cube.side,
                    ulp(std::abs(cube.origin) + cube.side));
        for (int c = 0; c <= kNodeOffsetMaxCode; ++c) {
            const auto code = static_cast<std::uint16_t>(c);
            const float x = decode_node_offset(code, cube.origin, cube.side);
            ASSERT_TRUE(std::isfinite(x));
            ASSERT_EQ(encode_node_offset(x, cube.origin, cube.side), code);
        }
    }
}

TEST(NodeOffset, ErrorWithinHalfAStep) {
    std::mt19937_64 rng(12);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (const Cube& cube : kCubes) {
        const double bound =
            kNodeOffsetMaxError * cube.side + 4.0 * ulp(std::abs(cube.origin) + cube.side);
        for (int n = 0; n < 100000; ++n) {
            const auto x = static_cast<float>(cube.origin + unit(rng) * cube.side);
            const float decoded = decode_node_offset(encode_node_offset(x, cube.origin, cube.side),
                                                     cube.origin, cube.side);
            ASSERT_LE(std::abs(static_cast<double>(decoded) - x), bound);
        }
    }
    EXPECT_EQ(encode_node_offset(kNaN, 0.0f, 1.0f), 0);
    EXPECT_EQ(encode_node_offset(-1.0f, 0.0f, 1.0f), 0);
    EXPECT_EQ(encode_node_offset(2.0f, 0.0f, 1.0f), 65535);
}

TEST(NodeOffset, ConservativeRadiusContainsTheOriginalSphere) {
    std::mt19937_64 rng(13);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const Vec3f origin(-5.0f, 100.0f, 0.25f);
    const float side = 3.0f;
    for (int n = 0; n < 20000; ++n) {
        const Vec3f centre =
            origin + side * Vec3f(static_cast<float>(unit(rng)), static_cast<float>(unit(rng)),
                                  static_cast<float>(unit(rng)));
        const auto radius = static_cast<float>(n % 2 == 0 ? 0.0 : unit(rng) * side);
        const Vec3f decoded =
            decode_node_position(encode_node_position(centre, origin, side), origin, side);
        const float conservative = conservative_sphere_radius(radius, centre, decoded);
        // The original sphere's farthest point from the decoded centre, in double.
        const double farthest =
            (centre.cast<double>() - decoded.cast<double>()).norm() + static_cast<double>(radius);
        ASSERT_GE(static_cast<double>(conservative), farthest);
        // And not wastefully larger: within the stated offset error plus a relative 2⁻¹⁹.
        ASSERT_LE(static_cast<double>(conservative),
                  radius + std::sqrt(3.0) * kNodeOffsetMaxError * side * 1.01 +
                      (radius + side) * 0x1p-19);
    }
}

// ---------------------------------------------------------------------------------------------
// Octahedral normals

/// Round trip of one direction: angle to the decoded normal, in double. The encoder receives
/// the float vector, so the error is measured against that.
double normal_error(const Vec3d& direction) {
    const Vec3f n = direction.cast<float>();
    return angle_between(n.cast<double>(), decode_normal(encode_normal(n)).cast<double>());
}

/// A direction whose octahedral square coordinates are (a, b)/32767 (a, b real, |a|, |b| ≤
/// 32767): the inverse of the map, in double, independent of the codec's own code.
Vec3d direction_of_square(double a, double b) {
    const double s = a / 32767.0;
    const double t = b / 32767.0;
    const double z = 1.0 - std::abs(s) - std::abs(t);
    if (z >= 0.0) {
        return Vec3d(s, t, z).normalized();
    }
    const double x = (1.0 - std::abs(t)) * (s >= 0.0 ? 1.0 : -1.0);
    const double y = (1.0 - std::abs(s)) * (t >= 0.0 ? 1.0 : -1.0);
    return Vec3d(x, y, z).normalized();
}

TEST(OctahedralNormal, AngularErrorWithinBoundOnRandomDirections) {
    std::mt19937_64 rng(21);
    double worst = 0.0;
    for (int n = 0; n < 2000000; ++n) {
        worst = std::max(worst, normal_error(random_direction(rng)));
    }
    EXPECT_LE(worst, kNormalMaxAngularError);
    std::cout << "worst angular error, random directions: " << worst << " rad\n";
}

TEST(OctahedralNormal, AngularErrorWithinBoundAtPolesEquatorAndEdges) {
    std::mt19937_64 rng(22);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::uniform_real_distribution<double> tiny(-1e-6, 1e-6);
    double worst = 0.0;
    for (int n = 0; n < 200000; ++n) {
        const double phi = 2.0 * std::numbers::pi * unit(rng);
        const double z = tiny(rng);
        // The equator z = 0 (the diamond's edge), and just above and below it.
        worst = std::max(worst, normal_error(Vec3d(std::cos(phi), std::sin(phi), 0.0)));
        worst = std::max(worst, normal_error(Vec3d(std::cos(phi), std::sin(phi), z)));
        // The octahedron's edges x = 0 and y = 0 (the square's axes and, for z < 0, its outer
        // boundary, where the fold glues (±1, t) to (±1, −t)).
        worst = std::max(worst, normal_error(Vec3d(0.0, std::cos(phi), std::sin(phi))));
        worst = std::max(worst, normal_error(Vec3d(std::cos(phi), 0.0, std::sin(phi))));
        worst = std::max(worst, normal_error(Vec3d(tiny(rng), std::cos(phi), std::sin(phi))));
        // Near the poles.
        worst = std::max(worst, normal_error(Vec3d(tiny(rng), tiny(rng), 1.0)));
        worst = std::max(worst, normal_error(Vec3d(tiny(rng), tiny(rng), -1.0)));
    }
    EXPECT_LE(worst, kNormalMaxAngularError);
}

TEST(OctahedralNormal, BoundIsTightAtTheOctantCentres) {
    // The worst cells (header comment): around the octant centres, at the points of a grid
    // cell farthest from its corners. Sampling cells there, in all eight octants, must reach
    // close to the bound and never exceed it.
    std::mt19937_64 rng(23);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    double worst = 0.0;
    for (int n = 0; n < 400000; ++n) {
        const double a = std::floor(32767.0 / 3.0 + 200.0 * (unit(rng) - 0.5)) + unit(rng);
        const double b = std::floor(32767.0 / 3.0 + 200.0 * (unit(rng) - 0.5)) + unit(rng);
        const Vec3d upper = direction_of_square(a, b);
        for (int octant = 0; octant < 8; ++octant) {
            const Vec3d sign((octant & 1) != 0 ? -1.0 : 1.0, (octant & 2) != 0 ? -1.0 : 1.0,
                             (octant & 4) != 0 ? -1.0 : 1.0);
            worst = std::max(worst, normal_error(upper.cwiseProduct(sign)));
        }
    }
    EXPECT_LE(worst, kNormalMaxAngularError);
    EXPECT_GE(worst, 0.97 * std::sqrt(2.0) / 32767.0);
}

TEST(OctahedralNormal, AxesPolesAndEquatorDecodeExactly) {
    for (int axis = 0; axis < 3; ++axis) {
        for (const float sign : {1.0f, -1.0f}) {
            Vec3f n = Vec3f::Zero();
            n[axis] = sign;
            EXPECT_EQ(decode_normal(encode_normal(n)), n) << n.transpose();
        }
    }
    // Every code on the diamond's edge |a| + |b| = 32767 decodes to z = 0 exactly and
    // round-trips; every code on the square's boundary decodes onto the plane x = 0 or y = 0.
    for (int a = -32767; a <= 32767; ++a) {
        const int b_magnitude = 32767 - std::abs(a);
        for (const int b : {b_magnitude, -b_magnitude}) {
            const NormalCode code{static_cast<std::uint16_t>(a + 32767),
                                  static_cast<std::uint16_t>(b + 32767)};
            const Vec3f n = decode_normal(code);
            ASSERT_EQ(n.z(), 0.0f) << code;
            ASSERT_EQ(encode_normal(n), code) << code;
        }
        const Vec3f on_u_edge = decode_normal({65534, static_cast<std::uint16_t>(a + 32767)});
        const Vec3f on_v_edge = decode_normal({static_cast<std::uint16_t>(a + 32767), 0});
        ASSERT_EQ(on_u_edge.y(), 0.0f);
        ASSERT_EQ(on_v_edge.x(), 0.0f);
        // The fold glues (1, t) to (1, −t): both decode to the same normal.
        ASSERT_EQ(on_u_edge, decode_normal({65534, static_cast<std::uint16_t>(32767 - a)}));
    }
    // The unused code 65535 reads as 65534.
    EXPECT_EQ(decode_normal({65535, 1000}), decode_normal({65534, 1000}));
    EXPECT_EQ(decode_normal({1000, 65535}), decode_normal({1000, 65534}));
}

TEST(OctahedralNormal, DecodedNormalsRoundTrip) {
    // Re-encoding a decoded normal reproduces that normal (the code too, except on the
    // square's boundary, where two codes share a normal).
    for (int u = 0; u < 65536; u += 7) {
        for (int v = 0; v < 65536; v += 331) {
            const NormalCode code{static_cast<std::uint16_t>(u), static_cast<std::uint16_t>(v)};
            const Vec3f n = decode_normal(code);
            ASSERT_EQ(decode_normal(encode_normal(n)), n) << code;
        }
    }
}

TEST(OctahedralNormal, EveryCodeDecodesToAFiniteUnitVector) {
    // Dense over the 2³² codes: every u against a set of v (with the special values), and
    // the other way round. The header proves the L1 norm before normalisation is 32767.
    std::vector<int> some;
    for (int c = 0; c < 65536; c += 251) {
        some.push_back(c);
    }
    for (const int c : {1, 2, 32766, 32767, 32768, 65533, 65534, 65535}) {
        some.push_back(c);
    }
    double worst = 0.0;
    for (int all = 0; all < 65536; ++all) {
        for (const int s : some) {
            for (const NormalCode code :
                 {NormalCode{static_cast<std::uint16_t>(all), static_cast<std::uint16_t>(s)},
                  NormalCode{static_cast<std::uint16_t>(s), static_cast<std::uint16_t>(all)}}) {
                const Vec3f n = decode_normal(code);
                ASSERT_TRUE(n.allFinite()) << code;
                worst = std::max(worst, std::abs(n.cast<double>().norm() - 1.0));
            }
        }
    }
    EXPECT_LE(worst, kNormalMaxLengthError);
}

TEST(OctahedralNormal, DegenerateInputEncodesAsPlusZAndLengthDoesNotMatter) {
    const NormalCode plus_z{};
    EXPECT_EQ(decode_normal(plus_z), Vec3f(0.0f, 0.0f, 1.0f));
    EXPECT_EQ(encode_normal(Vec3f::Zero()), plus_z);
    EXPECT_EQ(encode_normal(Vec3f(0.0f, 0.0f, -0.0f)), plus_z);
    EXPECT_EQ(encode_normal(Vec3f(kNaN, 0.0f, 1.0f)), plus_z);
    EXPECT_EQ(encode_normal(Vec3f(kInfinity, 0.0f, 1.0f)), plus_z);
    std::mt19937_64 rng(24);
    for (int n = 0; n < 1000; ++n) {
        const Vec3f d = random_direction(rng).cast<float>();
        EXPECT_EQ(encode_normal(d), encode_normal(4.0f * d));
        EXPECT_EQ(encode_normal(d), encode_normal(0.25f * d));
    }
}

// ---------------------------------------------------------------------------------------------
// Half floats and gradients

std::uint16_t eigen_half_bits(float x) {
    return Eigen::numext::bit_cast<std::uint16_t>(Eigen::half(x));
}

TEST(HalfFloat, EveryCodeDecodesFiniteAndFiniteCodesRoundTrip) {
    for (int c = 0; c < 65536; ++c) {
        const auto code = static_cast<std::uint16_t>(c);
        const float x = decode_half(code);
        ASSERT_TRUE(std::isfinite(x)) << c;
        const bool inf_or_nan = (c & 0x7c00) == 0x7c00;
        if (inf_or_nan) {
            const bool inf = (c & 0x03ff) == 0;
            ASSERT_EQ(x, inf ? std::copysign(kHalfMax, (c & 0x8000) != 0 ? -1.0f : 1.0f) : 0.0f)
                << c;
        } else {
            ASSERT_EQ(x, static_cast<float>(Eigen::numext::bit_cast<Eigen::half>(code))) << c;
            ASSERT_EQ(encode_half(x), code) << c;
        }
    }
}

TEST(HalfFloat, RoundsToNearestEvenAtEveryTieLikeIeee) {
    // Between each pair of neighbouring finite halves: the midpoint (exact in float) and the
    // floats on either side of it, against Eigen::half's IEEE round-to-nearest-even.
    for (int c = 0; c < 0x7bff; ++c) {
        for (const float sign : {1.0f, -1.0f}) {
            const double low = decode_half(static_cast<std::uint16_t>(c));
            const double high = decode_half(static_cast<std::uint16_t>(c + 1));
            const auto mid = static_cast<float>(sign * 0.5 * (low + high));
            for (const float x : {mid, std::nextafter(mid, 0.0f), std::nextafter(mid, 2 * mid)}) {
                ASSERT_EQ(encode_half(x), eigen_half_bits(x)) << x;
            }
        }
    }
}

TEST(HalfFloat, RelativeErrorWithinBoundOverTheWholeRange) {
    std::mt19937_64 rng(31);
    std::uniform_real_distribution<double> exponent(-30.0, 16.0);
    std::uniform_int_distribution<int> coin(0, 1);
    double worst_relative = 0.0;
    double worst_absolute_subnormal = 0.0;
    for (int n = 0; n < 2000000; ++n) {
        const auto x = static_cast<float>((coin(rng) != 0 ? -1.0 : 1.0) * std::exp2(exponent(rng)));
        if (std::abs(x) > kHalfMax) {
            ASSERT_EQ(std::abs(decode_half(encode_half(x))), kHalfMax) << x;
            continue;
        }
        const float decoded = decode_half(encode_half(x));
        ASSERT_EQ(encode_half(x), eigen_half_bits(x)) << x;  // in range: IEEE rounding
        const double error = std::abs(static_cast<double>(decoded) - x);
        if (std::abs(x) >= kHalfMinNormal) {
            worst_relative = std::max(worst_relative, error / std::abs(x));
        } else {
            worst_absolute_subnormal = std::max(worst_absolute_subnormal, error);
        }
    }
    EXPECT_LE(worst_relative, kHalfRelativeError);
    EXPECT_LE(worst_absolute_subnormal, kHalfSubnormalAbsoluteError);
}

TEST(HalfFloat, SaturatesInsteadOfInfAndMapsNanToZero) {
    EXPECT_EQ(decode_half(encode_half(65504.0f)), 65504.0f);
    EXPECT_EQ(decode_half(encode_half(65519.99f)), 65504.0f);  // IEEE: rounds down anyway
    EXPECT_EQ(decode_half(encode_half(65520.0f)), 65504.0f);   // IEEE: Inf
    EXPECT_EQ(decode_half(encode_half(1e30f)), 65504.0f);
    EXPECT_EQ(decode_half(encode_half(std::numeric_limits<float>::max())), 65504.0f);
    EXPECT_EQ(decode_half(encode_half(kInfinity)), 65504.0f);
    EXPECT_EQ(decode_half(encode_half(-kInfinity)), -65504.0f);
    EXPECT_EQ(encode_half(kNaN), 0);
    EXPECT_EQ(encode_half(-kNaN), 0);
    // Tiny values flush to a signed zero, the smallest subnormals survive.
    EXPECT_EQ(decode_half(encode_half(1e-9f)), 0.0f);
    EXPECT_EQ(decode_half(encode_half(0x1p-24f)), 0x1p-24f);
    EXPECT_EQ(decode_half(encode_half(0x1.8p-25f)), 0x1p-24f);
    EXPECT_EQ(encode_half(-0.0f), 0x8000);
}

TEST(GradientCode, EntriesRoundTripColumnMajorWithinTheRelativeBound) {
    Mat2f g;
    g << 1.0f / 0.01f, -3.3e-3f, 7.25e2f, -1.0f / 3.0f;
    const GradientCode code = encode_gradient(g);
    EXPECT_EQ(code[1], encode_half(g(1, 0)));
    EXPECT_EQ(code[2], encode_half(g(0, 1)));
    const Mat2f decoded = decode_gradient(code);
    for (int i = 0; i < 4; ++i) {
        EXPECT_LE(std::abs(decoded(i) - g(i)), kHalfRelativeError * std::abs(g(i))) << i;
    }
    Mat2f extreme;
    extreme << 1e9f, kNaN, -kInfinity, 1e-12f;
    EXPECT_EQ(decode_gradient(encode_gradient(extreme)),
              (Mat2f() << kHalfMax, 0.0f, -kHalfMax, 0.0f).finished());
}

// ---------------------------------------------------------------------------------------------
// Tangent-frame orientation

/// Normals that stress the canonical basis: poles, the z = ±0 switch, near −z, random, and
/// decoded normals next to the seams.
std::vector<Vec3f> stress_normals() {
    std::vector<Vec3f> normals = {{0.0f, 0.0f, 1.0f},
                                  {0.0f, 0.0f, -1.0f},
                                  {1.0f, 0.0f, 0.0f},
                                  {-1.0f, 0.0f, 0.0f},
                                  {0.0f, 1.0f, 0.0f},
                                  {0.0f, -1.0f, 0.0f},
                                  {1.0f, 0.0f, -0.0f},
                                  {0.6f, 0.8f, -0.0f},
                                  {0.6f, -0.8f, 0.0f},
                                  {1e-4f, 0.0f, -1.0f},
                                  {0.0f, 1e-4f, -1.0f},
                                  {1e-4f, 1e-4f, 1.0f},
                                  decode_normal({0, 0}),
                                  decode_normal({65534, 65534}),
                                  decode_normal({32767, 0}),
                                  decode_normal({12345, 40000}),
                                  decode_normal({32767, 65534}),
                                  decode_normal({1, 32766})};
    std::mt19937_64 rng(41);
    for (int n = 0; n < 2000; ++n) {
        normals.push_back(random_direction(rng).cast<float>());
    }
    for (Vec3f& n : normals) {
        n.normalize();
    }
    return normals;
}

TEST(CanonicalTangent, OrthonormalAndRightHandedForEveryNormal) {
    for (const Vec3f& n : stress_normals()) {
        const Vec3f t = canonical_tangent(n);
        const Vec3f b = canonical_bitangent(n);
        ASSERT_TRUE(t.allFinite() && b.allFinite()) << n.transpose();
        ASSERT_NEAR(t.norm(), 1.0f, 1e-6f) << n.transpose();
        ASSERT_NEAR(b.norm(), 1.0f, 1e-6f) << n.transpose();
        ASSERT_NEAR(t.dot(n), 0.0f, 1e-6f) << n.transpose();
        ASSERT_NEAR(b.dot(n), 0.0f, 1e-6f) << n.transpose();
        ASSERT_LE((n.cross(t) - b).norm(), 1e-6f) << n.transpose();
    }
}

/// Signed angle from a to b about the unit axis n, in double, for a and b orthogonal to n.
double signed_angle(const Vec3d& a, const Vec3d& b, const Vec3d& n) {
    return std::atan2(a.cross(b).dot(n), a.dot(b));
}

TEST(TangentAngle, ErrorWithinBoundAndEveryCodeRoundTrips) {
    std::mt19937_64 rng(42);
    std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi);
    double worst = 0.0;
    for (const Vec3f& n : stress_normals()) {
        const Vec3d nd = n.cast<double>();
        const Vec3d t0 = canonical_tangent(n).cast<double>();
        const Vec3d b0 = nd.cross(t0);
        for (int k = 0; k < 200; ++k) {
            const double theta = angle(rng);
            const Vec3f tangent = (std::cos(theta) * t0 + std::sin(theta) * b0).cast<float>();
            const Vec3f decoded = decode_tangent(encode_tangent_angle(tangent, n), n);
            ASSERT_NEAR(decoded.norm(), 1.0f, 1e-6f);
            ASSERT_NEAR(decoded.dot(n), 0.0f, 1e-6f);
            // Reference: the angle between the tangent's and the decoded tangent's projections.
            const Vec3d p = tangent.cast<double>() - tangent.cast<double>().dot(nd) * nd;
            const Vec3d q = decoded.cast<double>() - decoded.cast<double>().dot(nd) * nd;
            worst = std::max(worst, std::abs(signed_angle(p, q, nd)));
        }
    }
    EXPECT_LE(worst, kTangentAngleMaxError);
    EXPECT_GE(worst, 0.9 * 0.5 * kTangentAngleStep);

    for (const Vec3f& n :
         {Vec3f(0.0f, 0.0f, 1.0f), Vec3f(0.0f, 0.0f, -1.0f), decode_normal({12345, 40000})}) {
        for (int c = 0; c < 65536; ++c) {
            const auto code = static_cast<std::uint16_t>(c);
            const Vec3f t = decode_tangent(code, n);
            ASSERT_TRUE(t.allFinite());
            ASSERT_EQ(encode_tangent_angle(t, n), code) << c;
        }
    }
}

TEST(TangentAngle, CanonicalTangentIsCodeZeroExactlyAndDegenerateTangentsGiveZero) {
    for (const Vec3f& n : stress_normals()) {
        EXPECT_EQ(encode_tangent_angle(canonical_tangent(n), n), 0) << n.transpose();
        EXPECT_EQ(decode_tangent(0, n), canonical_tangent(n));
        EXPECT_EQ(encode_tangent_angle(Vec3f::Zero(), n), 0);
        EXPECT_EQ(encode_tangent_angle(Vec3f(kNaN, 0.0f, 0.0f), n), 0);
    }
    // Counter-clockwise about the normal: a quarter turn is n × t.
    const Vec3f n = decode_normal({12345, 40000});
    EXPECT_EQ(encode_tangent_angle(n.cross(canonical_tangent(n)), n), 16384);
    EXPECT_EQ(encode_tangent_angle(-canonical_tangent(n), n), 32768);
}

// ---------------------------------------------------------------------------------------------
// Material scalars

TEST(Coverage8, RoundTripsWithinTwoUnitStepsAndSaturatesAtTwo) {
    double worst = 0.0;
    for (int i = 0; i <= 200000; ++i) {
        const auto c = static_cast<float>(i / 1e5);
        worst = std::max(worst,
                         std::abs(static_cast<double>(decode_coverage8(encode_coverage8(c))) - c));
    }
    EXPECT_LE(worst, 2.0 * kUnit8MaxError + 1e-7);
    EXPECT_EQ(decode_coverage8(encode_coverage8(1.0f)), 2.0f * decode_unit8(encode_unit8(0.5f)));
    EXPECT_EQ(decode_coverage8(encode_coverage8(7.0f)), 2.0f);
    EXPECT_EQ(decode_coverage8(encode_coverage8(0.0f)), 0.0f);
    EXPECT_EQ(encode_coverage8(kNaN), 0);
}

TEST(Offset8, ExhaustiveRoundTripErrorBoundSymmetryAndSaturation) {
    for (int c = -127; c <= 127; ++c) {
        const auto code = static_cast<std::int8_t>(c);
        ASSERT_EQ(encode_offset8(decode_offset8(code)), code);
        ASSERT_EQ(decode_offset8(code), static_cast<float>(c / 127.0));
    }
    double worst = 0.0;
    for (int i = -1000000; i <= 1000000; ++i) {
        const auto x = static_cast<float>(i / 1e6);
        worst =
            std::max(worst, std::abs(static_cast<double>(decode_offset8(encode_offset8(x))) - x));
        ASSERT_EQ(encode_offset8(-x), -encode_offset8(x)) << x;
    }
    EXPECT_LE(worst, kOffset8MaxError + 1e-7);  // + the float rounding of c/127
    EXPECT_EQ(encode_offset8(0.0f), 0);
    EXPECT_EQ(encode_offset8(-1.5f), -127);
    EXPECT_EQ(encode_offset8(1.5f), 127);
    EXPECT_EQ(encode_offset8(kInfinity), 127);
    EXPECT_EQ(encode_offset8(-kInfinity), -127);
    EXPECT_EQ(encode_offset8(kNaN), 0);
}

TEST(Unit8, ExhaustiveRoundTripErrorBoundAndSaturation) {
    for (int c = 0; c < 256; ++c) {
        const auto code = static_cast<std::uint8_t>(c);
        ASSERT_EQ(encode_unit8(decode_unit8(code)), code);
        ASSERT_EQ(decode_unit8(code), static_cast<float>(c / 255.0));
    }
    double worst = 0.0;
    for (int i = 0; i <= 1000000; ++i) {
        const auto x = static_cast<float>(i / 1e6);
        worst = std::max(worst, std::abs(static_cast<double>(decode_unit8(encode_unit8(x))) - x));
    }
    EXPECT_LE(worst, kUnit8MaxError + 1e-7);  // + the float rounding of c/255
    EXPECT_EQ(encode_unit8(-0.5f), 0);
    EXPECT_EQ(encode_unit8(1.5f), 255);
    EXPECT_EQ(encode_unit8(kInfinity), 255);
    EXPECT_EQ(encode_unit8(-kInfinity), 0);
    EXPECT_EQ(encode_unit8(kNaN), 0);
}

double srgb_to_linear_reference(double s) {
    return s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4);
}

TEST(Srgb8, TableIsTheSrgbCurveAndStrictlyIncreasing) {
    for (int c = 0; c < 256; ++c) {
        const double reference = srgb_to_linear_reference(c / 255.0);
        ASSERT_NEAR(decode_srgb8(static_cast<std::uint8_t>(c)), reference, ulp(reference)) << c;
        if (c > 0) {
            ASSERT_GT(decode_srgb8(static_cast<std::uint8_t>(c)),
                      decode_srgb8(static_cast<std::uint8_t>(c - 1)));
        }
        ASSERT_EQ(encode_srgb8(decode_srgb8(static_cast<std::uint8_t>(c))), c);
    }
}

TEST(Srgb8, LinearErrorWithinBoundAndNearestCode) {
    double worst = 0.0;
    double worst_dark = 0.0;
    for (int i = 0; i <= 2000000; ++i) {
        const auto x = static_cast<float>(i / 2e6);
        const std::uint8_t code = encode_srgb8(x);
        const double error = std::abs(static_cast<double>(decode_srgb8(code)) - x);
        worst = std::max(worst, error);
        if (x <= kSrgb8DarkLimit) {
            worst_dark = std::max(worst_dark, error);
        }
        // Nearest in linear units: neither neighbour is closer.
        if (code > 0) {
            ASSERT_LE(error, std::abs(static_cast<double>(decode_srgb8(code - 1)) - x));
        }
        if (code < 255) {
            ASSERT_LE(error, std::abs(static_cast<double>(decode_srgb8(code + 1)) - x));
        }
    }
    EXPECT_LE(worst, kSrgb8MaxLinearError);
    EXPECT_GE(worst, 0.99 * kSrgb8MaxLinearError);
    EXPECT_LE(worst_dark, kSrgb8MaxDarkLinearError);
    EXPECT_EQ(encode_srgb8(-1.0f), 0);
    EXPECT_EQ(encode_srgb8(2.0f), 255);
    EXPECT_EQ(encode_srgb8(kNaN), 0);
    EXPECT_EQ(encode_rgb8(Rgb(0.0f, 0.5f, 1.0f)), (Rgb8Code{0, encode_srgb8(0.5f), 255}));
    EXPECT_EQ(decode_rgb8({0, 255, 0})[1], 1.0f);
}

TEST(Phong8, TableIsLogarithmicAndRelativeErrorWithinBound) {
    for (int c = 0; c < 256; ++c) {
        const double reference = std::pow(10000.0, c / 255.0);
        ASSERT_NEAR(decode_phong8(static_cast<std::uint8_t>(c)), reference, ulp(reference)) << c;
        ASSERT_EQ(encode_phong8(decode_phong8(static_cast<std::uint8_t>(c))), c);
    }
    double worst = 0.0;
    for (int i = 0; i <= 1000000; ++i) {
        const auto exponent = static_cast<float>(std::pow(10000.0, i / 1e6));
        const double decoded = decode_phong8(encode_phong8(exponent));
        worst = std::max(worst, std::abs(decoded - exponent) / exponent);
    }
    EXPECT_LE(worst, kPhong8MaxRelativeError);
    EXPECT_GE(worst, 0.99 * kPhong8MaxRelativeError);
    EXPECT_EQ(decode_phong8(encode_phong8(0.5f)), 1.0f);
    EXPECT_EQ(decode_phong8(encode_phong8(-3.0f)), 1.0f);
    EXPECT_EQ(decode_phong8(encode_phong8(kNaN)), 1.0f);
    EXPECT_EQ(decode_phong8(encode_phong8(1e6f)), 10000.0f);
    EXPECT_EQ(decode_phong8(encode_phong8(kInfinity)), 10000.0f);
}

TEST(Ior8, ErrorWithinBoundAndSaturation) {
    for (int c = 0; c < 256; ++c) {
        const auto code = static_cast<std::uint8_t>(c);
        ASSERT_NEAR(decode_ior8(code), 1.0 + 2.0 * c / 255.0, 2e-7) << c;
        ASSERT_EQ(encode_ior8(decode_ior8(code)), code) << c;
    }
    double worst = 0.0;
    for (int i = 0; i <= 1000000; ++i) {
        const auto ior = static_cast<float>(1.0 + 2.0 * i / 1e6);
        worst = std::max(worst, std::abs(static_cast<double>(decode_ior8(encode_ior8(ior))) - ior));
    }
    EXPECT_LE(worst, kIor8MaxError + 1e-6);  // + float rounding of (η − 1)/2 and of the decode
    EXPECT_EQ(decode_ior8(encode_ior8(1.5f)), decode_ior8(64));
    EXPECT_EQ(decode_ior8(encode_ior8(0.5f)), 1.0f);
    EXPECT_EQ(decode_ior8(encode_ior8(4.0f)), 3.0f);
    EXPECT_EQ(decode_ior8(encode_ior8(kNaN)), 1.0f);
}

TEST(NormalLength8, ErrorWithinBoundFinestNearOneAndSaturation) {
    for (int c = 0; c < 256; ++c) {
        const auto code = static_cast<std::uint8_t>(c);
        const double root = c / 255.0;
        ASSERT_NEAR(decode_normal_length8(code), 1.0 - root * root, 2e-7) << c;
        ASSERT_EQ(encode_normal_length8(decode_normal_length8(code)), code) << c;
    }
    for (int i = 0; i <= 1000000; ++i) {
        const auto length = static_cast<float>(i / 1e6);
        const double error = std::abs(
            static_cast<double>(decode_normal_length8(encode_normal_length8(length))) - length);
        ASSERT_LE(error, normal_length8_max_error(length)) << length;
    }
    // What the code is for: Toksvig's exponent ℓ·p/(ℓ + p·(1 − ℓ)) of p = 300 keeps within 2 % for
    // spreads of a few degrees (1 − ℓ ≈ θ²/2); a linear code rounds a spread of one or two degrees
    // to none, and the exponent is 5–18 % off.
    const auto toksvig = [](double p, double l) { return l * p / (l + p * (1.0 - l)); };
    for (const double degrees : {0.5, 1.0, 2.0, 5.0}) {
        const double theta = degrees * std::numbers::pi / 180.0;
        const auto length = static_cast<float>(1.0 - 0.5 * theta * theta);
        const double decoded = decode_normal_length8(encode_normal_length8(length));
        EXPECT_NEAR(toksvig(300.0, decoded) / toksvig(300.0, length), 1.0, 0.02) << degrees;
        if (degrees < 1.0 || degrees > 2.0) {
            continue;  // there the linear code is about as good (within 1 % at 0.5°)
        }
        EXPECT_GT(
            std::abs(toksvig(300.0, decode_unit8(encode_unit8(length))) / toksvig(300.0, length) -
                     1.0),
            0.02)
            << degrees;
    }
    EXPECT_EQ(decode_normal_length8(encode_normal_length8(1.0f)), 1.0f);
    EXPECT_EQ(decode_normal_length8(encode_normal_length8(0.0f)), 0.0f);
    EXPECT_EQ(decode_normal_length8(encode_normal_length8(2.0f)), 1.0f);
    EXPECT_EQ(decode_normal_length8(encode_normal_length8(-1.0f)), 0.0f);
    EXPECT_EQ(decode_normal_length8(encode_normal_length8(kNaN)), 1.0f);
}

TEST(MaterialCodes, NoCodeDecodesToANonFiniteValue) {
    for (int c = 0; c < 256; ++c) {
        const auto code = static_cast<std::uint8_t>(c);
        ASSERT_TRUE(std::isfinite(decode_unit8(code)));
        ASSERT_TRUE(std::isfinite(decode_srgb8(code)));
        ASSERT_TRUE(std::isfinite(decode_phong8(code)));
        ASSERT_TRUE(std::isfinite(decode_ior8(code)));
        ASSERT_TRUE(std::isfinite(decode_normal_length8(code)));
    }
}

}  // namespace
}  // namespace mrt
