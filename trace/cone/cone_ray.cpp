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

std::ostream& operator<<(std::ostream& os, const SphereInRayFrame& s) {
    return os << "SphereInRayFrame{t " << s.t << ", offset (" << s.offset.x() << ", "
              << s.offset.y() << "), radius " << s.radius << "}";
}

}  // namespace mrt
