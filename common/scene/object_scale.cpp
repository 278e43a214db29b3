#include "common/scene/object_scale.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace mrt {
namespace {

/// The binary exponent e of the mesh's largest |coordinate| m (m = f·2^e, f in [0.5, 1)), or 0
/// for an empty or degenerate mesh.
int magnitude_exponent(const Mesh& mesh) {
    float largest = 0.0f;
    for (const Vec3f& p : mesh.positions) {
        largest = std::max(largest, p.cwiseAbs().maxCoeff());
    }
    if (!(largest > 0.0f) || !std::isfinite(largest)) {
        return 0;
    }
    int exponent = 0;
    std::frexp(largest, &exponent);
    return exponent;
}

}  // namespace

void normalize_object_scales(Scene& scene) {
    std::vector<int> shift(scene.meshes.size(), 0);
    for (std::size_t i = 0; i < scene.meshes.size(); ++i) {
        const int exponent = magnitude_exponent(scene.meshes[i]);
        if (std::abs(exponent) > kObjectScaleExponentLimit) {
            shift[i] = exponent;
        }
    }
    // A mesh is rescaled only if every instance of it can take the inverse power in float.
    for (const Group& group : scene.groups) {
        for (const Instance& child : group.children) {
            if (child.kind != Instance::Kind::Mesh || shift[child.index] == 0) {
                continue;
            }
            const Mat3f scaled = child.transform.linear() * std::ldexp(1.0f, shift[child.index]);
            if (!scaled.allFinite()) {
                shift[child.index] = 0;
            }
        }
    }
    for (std::size_t i = 0; i < scene.meshes.size(); ++i) {
        if (shift[i] == 0) {
            continue;
        }
        const float factor = std::ldexp(1.0f, -shift[i]);
        for (Vec3f& p : scene.meshes[i].positions) {
            p *= factor;
        }
    }
    for (Group& group : scene.groups) {
        for (Instance& child : group.children) {
            if (child.kind == Instance::Kind::Mesh && shift[child.index] != 0) {
                child.transform.linear() *= std::ldexp(1.0f, shift[child.index]);
            }
        }
    }
}

}  // namespace mrt
