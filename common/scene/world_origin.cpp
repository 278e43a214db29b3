#include "common/scene/world_origin.h"

namespace mrt {

Vec3d choose_world_origin(const Vec3d& eye, const Vec3d& look_at) {
    const double view_distance = (look_at - eye).norm();
    const bool near = eye.cwiseAbs().maxCoeff() <= kNearOriginViewDistances * view_distance;
    return near ? Vec3d::Zero() : eye;
}

}  // namespace mrt
