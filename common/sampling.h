#pragma once
// Warps of uniform [0,1)² samples onto the domains the tracers sample (lens, area lights).

#include "common/math.h"

namespace mrt {

/// Concentric mapping of [0,1)² onto the unit disc (Shirley & Chiu 1997): area-preserving and
/// low distortion, so stratified samples stay stratified.
Vec2f concentric_disc(float u, float v);

}  // namespace mrt
