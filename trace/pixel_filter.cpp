#include "trace/pixel_filter.h"

#include "common/error.h"

#include <cstdlib>
#include <ostream>

namespace mrt {

PixelFilter parse_pixel_filter(const std::string& text) {
    if (text == "box") {
        return PixelFilter::box();
    }
    const std::string gaussian = "gaussian";
    if (text.rfind(gaussian, 0) == 0) {
        if (text.size() == gaussian.size()) {
            return PixelFilter::gaussian(0.5f);
        }
        if (text[gaussian.size()] == ':') {
            const std::string number = text.substr(gaussian.size() + 1);
            char* end = nullptr;
            const float sigma = std::strtof(number.c_str(), &end);
            if (!number.empty() && end == number.c_str() + number.size() && std::isfinite(sigma) &&
                sigma > 0.0f && sigma <= 16.0f) {
                return PixelFilter::gaussian(sigma);
            }
        }
    }
    throw Error("pixel filter: found \"" + text +
                "\", expected box, gaussian or gaussian:SIGMA with SIGMA in (0, 16] pixels");
}

std::ostream& operator<<(std::ostream& os, const PixelFilter& f) {
    if (f.kind == PixelFilter::Kind::Box) {
        return os << "PixelFilter{box, radius " << f.radius << "}";
    }
    return os << "PixelFilter{gaussian, sigma " << f.sigma << ", radius " << f.radius << "}";
}

}  // namespace mrt
