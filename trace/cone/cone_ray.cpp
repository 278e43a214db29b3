#include "trace/cone/cone_ray.h"

#include <ostream>

namespace mrt {

std::ostream& operator<<(std::ostream& os, const ConeRay& ray) {
    const Eigen::IOFormat row(Eigen::StreamPrecision, Eigen::DontAlignCols, ", ", "; ", "", "", "[",
                              "]");
    return os << "ConeRay{origin " << ray.origin.transpose().format(row) << ", direction "
              << ray.direction.transpose().format(row) << ", start "
              << ray.cone.start_dev.format(row) << ", incr " << ray.cone.incr_dev.format(row)
              << "}";
}

MappedCone map_cone(const ConeRay& ray, const Affine3f& to_object) {
    MappedCone mapped;
    const Mat3f linear = to_object.linear();
    const Vec3f direction = linear * ray.direction;
    mapped.scale = direction.norm();
    ConeRay& to = mapped.ray;
    to.origin = to_object * ray.origin;
    to.direction = direction / mapped.scale;
    FootprintCone& cone = to.cone;
    orthonormal_basis(to.direction, cone.u, cone.v);
    const FootprintCone& from = ray.cone;
    const Mat2f b = cone.basis().transpose() * linear * from.basis();
    // The new t = scale · the old t, so the increments per unit of t shrink by the scale.
    cone.start_dev = b * from.start_dev;
    cone.incr_dev = b * from.incr_dev / mapped.scale;
    cone.blurred = from.blurred;
    cone.blur_start = b * from.blur_start;
    cone.blur_incr = b * from.blur_incr / mapped.scale;
    return mapped;
}

Mat3f similarity_turn(const Affine3f& to_object, float scale) {
    return to_object.linear() / scale;
}

MappedCone map_cone_similar(const ConeRay& ray, const Affine3f& to_object, const Mat3f& turn,
                            float scale) {
    MappedCone mapped;
    mapped.scale = scale;
    ConeRay& to = mapped.ray;
    to.origin = to_object * ray.origin;
    to.direction = turn * ray.direction;
    FootprintCone& cone = to.cone;
    const FootprintCone& from = ray.cone;
    cone.u = turn * from.u;
    cone.v = turn * from.v;
    // In the turned frame the map is scale·I: offsets scale, and per unit of the new t
    // (scale times the old) the increments stay.
    cone.start_dev = scale * from.start_dev;
    cone.incr_dev = from.incr_dev;
    cone.blurred = from.blurred;
    cone.blur_start = scale * from.blur_start;
    cone.blur_incr = from.blur_incr;
    return mapped;
}

std::ostream& operator<<(std::ostream& os, const SphereInRayFrame& s) {
    return os << "SphereInRayFrame{t " << s.t << ", offset (" << s.offset.x() << ", "
              << s.offset.y() << "), radius " << s.radius << "}";
}

}  // namespace mrt
