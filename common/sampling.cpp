#include "common/sampling.h"

#include <cmath>

namespace mrt {

Vec2f concentric_disc(float u, float v) {
    const float a = 2.0f * u - 1.0f;
    const float b = 2.0f * v - 1.0f;
    if (a == 0.0f && b == 0.0f) {
        return Vec2f::Zero();
    }
    float r;
    float phi;
    if (std::abs(a) > std::abs(b)) {
        r = a;
        phi = (kPi / 4.0f) * (b / a);
    } else {
        r = b;
        phi = (kPi / 2.0f) - (kPi / 4.0f) * (a / b);
    }
    return {r * std::cos(phi), r * std::sin(phi)};
}

}  // namespace mrt
