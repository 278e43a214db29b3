#pragma once
// Camera-relative world space: how the scene loader keeps single precision where the camera is.
//
// Every consumer of a Scene (the BVH of whitted and distributed, the point hierarchy of the
// preprocessor, the cone tracer) stores and intersects world space in float, whose spacing at
// 1e6 is 0.06: a scene translated that far is visibly faceted. So the loader parses every
// placement in double (JSON numbers are doubles), composes transforms in double, and, when the
// eye lies far from the file's origin, re-bases the world on the eye: the eye (Scene::world_origin)
// is subtracted from the camera, from the lights and from the transforms of the world's own
// objects (the root group's children), and only the differences are rounded to float. Meshes and
// procedural shapes are already stored in their object space, and the groups the world instances
// keep their object-local transforms, so nothing else moves. Everything after the loader sees
// camera-relative world space; Scene::world_origin adds the origin back for anyone who needs
// the file's coordinates.
//
// "Far" is relative to the view distance |look_at − eye|, so the rule is scale-invariant: a
// scene around the origin (the eye within kNearOriginViewDistances view distances of it, as in
// every scene of the project) is loaded with the numbers it was written with, bit for bit.
//
// Limitation: a translation far from the origin inside a group that the world instances (a
// group placed at the origin whose children sit at 1e6) is composed in float by the consumers,
// and loses what the file's own world-space floats would; place such groups with the world's
// transform instead.

#include "common/math/math.h"

namespace mrt {

/// Affine transform composed in double before it is rounded once to float.
using Affine3d = Eigen::Transform<double, 3, Eigen::Affine, Eigen::DontAlign>;

/// Up to this many view distances from the file's origin, the eye counts as near it (float
/// spacing at the eye is then at most 16 · 2^-24 ≈ 1e-6 of the view distance).
inline constexpr double kNearOriginViewDistances = 16.0;

/// The world position (file coordinates) that becomes the scene's origin: zero when the eye is
/// near the file's origin (largest coordinate within kNearOriginViewDistances · |look_at − eye|),
/// else the eye itself.
Vec3d choose_world_origin(const Vec3d& eye, const Vec3d& look_at);

/// Moves world-space placements of the file into the scene's camera-relative space: subtracts
/// the origin in double, then rounds once. Results may be non-finite (a point more than the
/// largest float away from the origin); the caller reports that at the value's JSON pointer.
class WorldFrame {
  public:
    WorldFrame() = default;
    explicit WorldFrame(const Vec3d& origin) : m_origin(origin) {}

    /// File position of the scene's origin.
    const Vec3d& origin() const { return m_origin; }
    /// A point in the file's world coordinates → scene coordinates.
    Vec3f point(const Vec3d& p) const { return (p - m_origin).cast<float>(); }
    /// A transform into the file's world space → into the scene's (translate(−origin) · t).
    Affine3f placement(const Affine3d& t) const {
        Affine3d moved = t;
        moved.translation() -= m_origin;
        return moved.cast<float>();
    }

  private:
    Vec3d m_origin = Vec3d::Zero();
};

}  // namespace mrt
