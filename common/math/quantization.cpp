#include "common/math/quantization.h"

#include <ostream>

namespace mrt {

float conservative_sphere_radius(float radius, const Vec3f& centre, const Vec3f& decoded_centre) {
    // The offset in double so that only the final sum is rounded; then push the sum up by a
    // relative 2⁻²⁰ (a few float ulps) and by the smallest normal float for radius 0.
    const double offset = (centre.cast<double>() - decoded_centre.cast<double>()).norm();
    const double bound = (static_cast<double>(radius) + offset) * (1.0 + 0x1p-20);
    return static_cast<float>(bound) + std::numeric_limits<float>::min();
}

namespace {

/// The octahedral square coordinates (s, t) ∈ [−1, 1]² of a non-zero direction, in double.
Vec2d octahedral_square(const Vec3d& n) {
    const double l1 = std::abs(n.x()) + std::abs(n.y()) + std::abs(n.z());
    const double x = n.x() / l1;
    const double y = n.y() / l1;
    if (n.z() >= 0.0) {
        return {x, y};
    }
    // Lower half: fold out over the diamond's edge; the sign of ±0 counts as +, as in the decode.
    const double sx = x >= 0.0 ? 1.0 : -1.0;
    const double sy = y >= 0.0 ? 1.0 : -1.0;
    return {(1.0 - std::abs(y)) * sx, (1.0 - std::abs(x)) * sy};
}

}  // namespace

NormalCode encode_normal(const Vec3f& n) {
    const Vec3d direction = n.cast<double>();
    const double length = direction.norm();
    if (!std::isfinite(length) || length == 0.0) {
        return NormalCode{};
    }
    const Vec3d unit = direction / length;
    const Vec2d square = octahedral_square(unit) * NormalCode::kCentre;
    // Cigolle et al.'s precise encoding: of the (up to) four grid points around the projected
    // point, keep the one whose decoded normal is closest in angle.
    NormalCode best;
    double best_angle = kInfinity;
    for (int corner = 0; corner < 4; ++corner) {
        const double a = (corner & 1) != 0 ? std::ceil(square.x()) : std::floor(square.x());
        const double b = (corner & 2) != 0 ? std::ceil(square.y()) : std::floor(square.y());
        const auto to_code = [](double s) {
            constexpr auto kMax = static_cast<double>(NormalCode::kCentre);
            const double clamped = std::clamp(s, -kMax, kMax);
            return static_cast<std::uint16_t>(clamped + NormalCode::kCentre);
        };
        const NormalCode candidate{to_code(a), to_code(b)};
        // The angle, not the cosine: the decoded float vector is unit only to ~1e-7, which
        // would swamp cosine differences of ~1e-9 between neighbouring codes.
        const Vec3d decoded = decode_normal(candidate).cast<double>();
        const double angle = std::atan2(decoded.cross(unit).norm(), decoded.dot(unit));
        if (angle < best_angle) {
            best_angle = angle;
            best = candidate;
        }
    }
    return best;
}

std::uint16_t encode_tangent_angle(const Vec3f& tangent, const Vec3f& normal) {
    Vec3f t;
    Vec3f b;
    orthonormal_basis(normal, t, b);
    const double along_t = tangent.cast<double>().dot(t.cast<double>());
    const double along_b = tangent.cast<double>().dot(b.cast<double>());
    if (!std::isfinite(along_t) || !std::isfinite(along_b) || (along_t == 0.0 && along_b == 0.0)) {
        return 0;
    }
    const double turns = std::atan2(along_b, along_t) / (2.0 * 3.14159265358979323846);  // (−½, ½]
    const auto steps = static_cast<long>(std::lround(turns * 65536.0));
    return static_cast<std::uint16_t>(steps & 0xffff);  // −k ≡ 65536 − k
}

std::ostream& operator<<(std::ostream& os, const NormalCode& code) {
    return os << "NormalCode{" << code.u << ", " << code.v << "}";
}

}  // namespace mrt
