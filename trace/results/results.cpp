#include "trace/results/results.h"

#include <ostream>

namespace mrt {

namespace {

/// The value, or "null" when it is unknown (as results.json writes it).
template <typename T>
std::string known(const std::optional<T>& value) {
    return value ? std::to_string(*value) : "null";
}

}  // namespace

std::ostream& operator<<(std::ostream& os, const ReferenceInfo& i) {
    return os << "ReferenceInfo{spp " << known(i.spp) << ", seconds " << known(i.seconds)
              << ", std_error " << known(i.std_error) << "}";
}

std::ostream& operator<<(std::ostream& os, const RunResult& r) {
    return os << "RunResult{" << r.spec << ", render " << r.render_seconds << " s, total "
              << r.total_seconds << " s, wall " << r.wall_seconds << " s, " << r.rays
              << " rays, RMSE " << r.rmse << ", PSNR " << r.psnr << ", SSIM " << r.ssim << "}";
}

}  // namespace mrt
