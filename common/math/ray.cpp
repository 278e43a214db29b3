#include "common/math/ray.h"

#include <ostream>

namespace mrt {

std::ostream& operator<<(std::ostream& os, const Ray& r) {
    const Eigen::IOFormat fmt(Eigen::StreamPrecision, Eigen::DontAlignCols, ", ", ", ", "", "", "(",
                              ")");
    return os << "Ray{origin " << r.origin.format(fmt) << ", direction " << r.direction.format(fmt)
              << ", t_max " << r.t_max << "}";
}

}  // namespace mrt
