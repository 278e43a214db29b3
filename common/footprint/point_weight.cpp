#include "common/footprint/point_weight.h"

#include <cmath>
#include <ostream>

namespace mrt {

PointWeightFrame point_weight_frame(const Mat2f& ray_footprint, float spacing) {
    PointWeightFrame frame;
    const Mat2f g = FootprintCone::widened(ray_footprint, kPointKernelRadius * spacing);
    const FootprintInverse inverse = FootprintCone::inverse(g);
    if (!(inverse.abs_det > 0.0f)) {
        return frame;
    }
    const float scale = kPointWeightSafety * spacing * spacing /
                        (kPi * inverse.abs_det * (1.0f - kPointWeightClip));
    if (!std::isfinite(scale)) {
        return frame;
    }
    frame.footprint = g;
    frame.inverse = inverse.inverse;
    frame.scale = scale;
    return frame;
}

PointWeightFrame point_weight_frame(const FootprintCone& cone, float t, float spacing,
                                    float max_anisotropy) {
    return point_weight_frame(FootprintCone::clamp_anisotropy(cone.at(t), max_anisotropy), spacing);
}

std::ostream& operator<<(std::ostream& os, const PointWeightFrame& frame) {
    const Eigen::IOFormat row(Eigen::StreamPrecision, Eigen::DontAlignCols, ", ", "; ", "", "", "[",
                              "]");
    return os << "PointWeightFrame{footprint " << frame.footprint.format(row) << ", inverse "
              << frame.inverse.format(row) << ", scale " << frame.scale << "}";
}

}  // namespace mrt
