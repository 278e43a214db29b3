#include "common/scene/mesh_light.h"

#include "common/system/error.h"

#include <algorithm>

namespace mrt {

MeshAreaLight::MeshAreaLight(std::vector<Triangle> triangles, const Vec3f& normal,
                             const Rgb& radiance)
    : m_triangles(std::move(triangles)), m_normal(normal), m_radiance(radiance) {
    if (m_triangles.empty()) {
        throw Error("a mesh area light needs at least one triangle");
    }
    // Summed in double: a light of a million small triangles keeps its area to float precision.
    double area = 0.0;
    Eigen::Vector3d moment = Eigen::Vector3d::Zero();
    m_cumulative_area.reserve(m_triangles.size());
    for (const Triangle& t : m_triangles) {
        const Eigen::Vector3d a = t[0].cast<double>();
        const Eigen::Vector3d b = t[1].cast<double>();
        const Eigen::Vector3d c = t[2].cast<double>();
        const double triangle_area = 0.5 * (b - a).cross(c - a).norm();
        area += triangle_area;
        moment += triangle_area * (a + b + c) / 3.0;
        m_cumulative_area.push_back(static_cast<float>(area));
    }
    m_area = static_cast<float>(area);
    m_centroid = area > 0.0
                     ? Vec3f((moment / area).cast<float>())
                     : Vec3f((m_triangles[0][0] + m_triangles[0][1] + m_triangles[0][2]) / 3.0f);
}

std::size_t MeshAreaLight::pick_triangle(float& u) const {
    const float target = u * m_area;
    const auto it = std::upper_bound(m_cumulative_area.begin(), m_cumulative_area.end(), target);
    const std::size_t index = std::min<std::size_t>(
        static_cast<std::size_t>(it - m_cumulative_area.begin()), m_triangles.size() - 1);
    const float before = index == 0 ? 0.0f : m_cumulative_area[index - 1];
    const float share = m_cumulative_area[index] - before;
    u = share > 0.0f ? std::clamp((target - before) / share, 0.0f, 0.99999994f) : 0.0f;
    return index;
}

}  // namespace mrt
