#include "trace/render/render.h"

#include "common/system/error.h"

namespace mrt {

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
