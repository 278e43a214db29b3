#include "trace/render/render.h"

#include "common/system/error.h"

#include <ostream>

namespace mrt {

std::ostream& operator<<(std::ostream& os, const RayCounters& c) {
    return print_fields(os, "RayCounters", c);
}

std::ostream& operator<<(std::ostream& os, const PixelWindow& w) {
    return os << "PixelWindow{[" << w.x0 << ", " << w.x1 << ") × [" << w.y0 << ", " << w.y1 << ")}";
}

Differentials parse_differentials(const std::string& text) {
    if (text == "when-read") {
        return Differentials::WhenRead;
    }
    if (text == "always") {
        return Differentials::Always;
    }
    throw Error("differentials: found \"" + text + "\", expected when-read or always");
}

std::string to_string(Differentials differentials) {
    return differentials == Differentials::Always ? "always" : "when-read";
}

}  // namespace mrt
