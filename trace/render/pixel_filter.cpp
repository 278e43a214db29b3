#include "trace/render/pixel_filter.h"

#include "common/system/error.h"

#include <array>
#include <charconv>
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

std::string to_string(const PixelFilter& f) {
    if (f.kind == PixelFilter::Kind::Box) {
        return "box";
    }
    // The shortest digits that read back to the same float.
    std::array<char, 32> digits{};
    const auto result = std::to_chars(digits.data(), digits.data() + digits.size(), f.sigma);
    return "gaussian:" + std::string(digits.data(), result.ptr);
}

std::ostream& operator<<(std::ostream& os, const PixelFilter& f) {
    if (f.kind == PixelFilter::Kind::Box) {
        return os << "PixelFilter{box, radius " << f.radius << "}";
    }
    return os << "PixelFilter{gaussian, sigma " << f.sigma << ", radius " << f.radius << "}";
}

}  // namespace mrt
