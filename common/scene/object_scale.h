#pragma once
// Object spaces of ordinary magnitude. A mesh may be written at any scale and placed by any
// transform: a sphere of radius 1e-13 scaled by 1e13 is a unit sphere in the world. The world
// transform is fine (it is inverted in double, common/math/invertibility.h), but the object space
// is not: the tracers intersect and the cone tracer weighs footprints in object space, where the
// squares and fourth powers of 1e±13 leave the float range (a triangle test of 1e-30 coordinates
// underflows; a cone's footprint matrix at 1e13 overflows). So a mesh whose coordinates are far
// from magnitude 1 is rescaled by a power of two, which is exact in binary floating point (no
// vertex moves relative to another, no normal or area changes but by that power), and the
// inverse power is folded into every instance that places it. The world is unchanged.

#include "common/scene/scene.h"

namespace mrt {

/// Meshes whose largest coordinate magnitude is within 2^±kObjectScaleExponentLimit are left
/// as they are (bit for bit: every scene of the project, and any scanned mesh in millimetres).
inline constexpr int kObjectScaleExponentLimit = 20;

/// Rescales every mesh whose largest |coordinate| lies outside 2^±kObjectScaleExponentLimit to
/// magnitude about 1 by a power of two, and multiplies the linear part of every mesh instance
/// placing it by the inverse power (exactly, in float). A mesh is left as it is when an instance
/// would leave the float range.
void normalize_object_scales(Scene& scene);

}  // namespace mrt
