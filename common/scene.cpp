#include "common/scene.h"

#include "common/error.h"
#include "common/invertibility.h"

#include <fmt/format.h>

#include <array>
#include <limits>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace mrt {

namespace {

/// Follows instances from a group, refusing what a hand-built Scene could get wrong (the loader
/// never produces either): out-of-range indices and cycles (deeper than there are groups).
void check_instance(const Scene& scene, const Instance& instance, std::size_t depth) {
    const std::size_t count =
        instance.kind == Instance::Kind::Mesh ? scene.meshes.size() : scene.groups.size();
    if (instance.index >= count) {
        throw Error(scene.file, "",
                    fmt::format("instance of {} {} out of range ({} exist)",
                                instance.kind == Instance::Kind::Mesh ? "mesh" : "group",
                                instance.index, count));
    }
    if (depth > scene.groups.size()) {
        throw Error(scene.file, "", "group instances form a cycle");
    }
}

std::uint64_t group_triangle_count(const Scene& scene, std::uint32_t group,
                                   std::vector<std::optional<std::uint64_t>>& memo,
                                   std::size_t depth) {
    if (memo[group]) {
        return *memo[group];
    }
    std::uint64_t total = 0;
    for (const Instance& child : scene.groups[group].children) {
        check_instance(scene, child, depth + 1);
        total += child.kind == Instance::Kind::Mesh
                     ? scene.meshes[child.index].triangle_count()
                     : group_triangle_count(scene, child.index, memo, depth + 1);
    }
    memo[group] = total;
    return total;
}

class Flattener {
  public:
    explicit Flattener(const Scene& scene) : m_scene(scene) {
        for (const Mesh& mesh : scene.meshes) {
            m_with_uvs = m_with_uvs || mesh.has_uvs();
        }
        m_out.name = scene.file.filename().string() + " (flattened)";
    }

    Mesh run() {
        if (m_scene.root < m_scene.groups.size()) {
            // Beyond 32-bit indices add_mesh refuses anyway, with a clearer message than a
            // failed reservation would give.
            const std::uint64_t triangles = m_scene.instanced_triangle_count();
            if (triangles <= std::numeric_limits<std::uint32_t>::max()) {
                m_out.triangles.reserve(triangles);
                m_out.materials.reserve(triangles);
            }
            add_group(m_scene.root, Affine3f::Identity(), 0);
        }
        return std::move(m_out);
    }

  private:
    void add_group(std::uint32_t group, const Affine3f& to_world, std::size_t depth) {
        for (const Instance& child : m_scene.groups[group].children) {
            check_instance(m_scene, child, depth + 1);
            const Affine3f child_to_world = to_world * child.transform;
            if (child.kind == Instance::Kind::Mesh) {
                add_mesh(m_scene.meshes[child.index], child_to_world);
            } else {
                add_group(child.index, child_to_world, depth + 1);
            }
        }
    }

    void add_mesh(const Mesh& mesh, const Affine3f& to_world) {
        const std::size_t base = m_out.positions.size();
        if (base + mesh.positions.size() > std::numeric_limits<std::uint32_t>::max()) {
            throw Error(m_scene.file, "", "too many vertices to flatten into one mesh");
        }
        const Mat3f normal_matrix = inverse_in_double(Mat3f(to_world.linear())).transpose();
        const bool has_normals = mesh.normals.size() == mesh.positions.size();
        for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
            m_out.positions.push_back(to_world * mesh.positions[i]);
            const Vec3f n = has_normals ? Vec3f(normal_matrix * mesh.normals[i]) : Vec3f::UnitZ();
            m_out.normals.push_back(n.normalized());
            if (m_with_uvs) {
                m_out.uvs.push_back(mesh.has_uvs() ? mesh.uvs[i] : Vec2f::Zero());
            }
        }
        // A mirroring transform turns counter-clockwise triangles clockwise; swapping two
        // corners keeps the winding consistent with the transformed normals.
        const bool mirrored = to_world.linear().cast<double>().determinant() < 0.0;
        const auto offset = static_cast<std::uint32_t>(base);
        for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
            const auto& tri = mesh.triangles[t];
            m_out.triangles.push_back(
                mirrored ? std::array{tri[0] + offset, tri[2] + offset, tri[1] + offset}
                         : std::array{tri[0] + offset, tri[1] + offset, tri[2] + offset});
            m_out.materials.push_back(t < mesh.materials.size() ? mesh.materials[t] : 0u);
        }
    }

    const Scene& m_scene;
    bool m_with_uvs = false;
    Mesh m_out;
};

std::string format_vec(const Vec3f& v) {
    return fmt::format("({}, {}, {})", v.x(), v.y(), v.z());
}

std::string format_rgb(const Rgb& c) {
    return fmt::format("({}, {}, {})", c[0], c[1], c[2]);
}

}  // namespace

std::uint64_t Scene::instanced_triangle_count() const {
    if (root >= groups.size()) {
        return 0;
    }
    std::vector<std::optional<std::uint64_t>> memo(groups.size());
    return group_triangle_count(*this, root, memo, 0);
}

std::uint64_t Scene::unique_triangle_count() const {
    std::uint64_t total = 0;
    for (const Mesh& mesh : meshes) {
        total += mesh.triangle_count();
    }
    return total;
}

Mesh flatten(const Scene& scene) {
    return Flattener(scene).run();
}

std::ostream& operator<<(std::ostream& os, const Camera& c) {
    constexpr float kDegreesPerRadian = 180.0f / kPi;
    return os << fmt::format(
               "Camera{{eye={}, look_at={}, up={}, fov={:.6g}°, resolution={}x{}, "
               "aperture_radius={}, focal_distance={}, pixel_aspect={}}}",
               format_vec(c.eye), format_vec(c.look_at), format_vec(c.up),
               c.vertical_fov * kDegreesPerRadian, c.width, c.height, c.aperture_radius,
               c.focal_distance, c.pixel_aspect);
}

std::ostream& operator<<(std::ostream& os, const Material& m) {
    os << fmt::format(
        "Material{{name=\"{}\", diffuse={}, specular={}, phong_exponent={}, reflectivity={}, "
        "transparency={}, ior={}, roughness={}, texture={}",
        m.name, format_rgb(m.diffuse), format_rgb(m.specular), m.phong_exponent, m.reflectivity,
        m.transparency, m.ior, m.roughness, m.texture);
    if (m.texture >= 0) {
        const auto& t = m.uv_transform.matrix();
        os << fmt::format(", uv_transform=[[{}, {}, {}], [{}, {}, {}]]", t(0, 0), t(0, 1), t(0, 2),
                          t(1, 0), t(1, 1), t(1, 2));
    }
    return os << "}";
}

}  // namespace mrt
