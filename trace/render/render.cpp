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
    if (const std::optional<Differentials> differentials = kDifferentialsNames.find(text)) {
        return *differentials;
    }
    throw Error("differentials: found \"" + text + "\", expected " + kDifferentialsNames.choices());
}

std::string to_string(Differentials differentials) {
    return std::string(kDifferentialsNames.name(differentials));
}

}  // namespace mrt
