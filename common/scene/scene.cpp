#include "common/scene/scene.h"

#include "common/math/invertibility.h"
#include "common/system/budgets.h"
#include "common/system/error.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <functional>
#include <limits>
#include <ostream>
#include <string>
#include <vector>

namespace mrt {

namespace {

void check_index(const Scene& scene, const Instance& instance) {
    const std::size_t count =
        instance.kind == Instance::Kind::Mesh ? scene.meshes.size() : scene.groups.size();
    if (instance.index >= count) {
        throw Error(scene.file, "",
                    fmt::format("instance of {} {} out of range ({} exist)",
                                instance.kind == Instance::Kind::Mesh ? "mesh" : "group",
                                instance.index, count));
    }
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
            add_group(m_scene.root);
        }
        return std::move(m_out);
    }

  private:
    void add_group(std::uint32_t root) {
        for_each_mesh_instance(m_scene, root, [this](std::uint32_t mesh, const Affine3f& to_world) {
            add_mesh(m_scene.meshes[mesh], to_world);
        });
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

void for_each_mesh_instance(const Scene& scene, std::uint32_t root,
                            const std::function<void(std::uint32_t, const Affine3f&)>& visit) {
    // Depth first with an explicit stack: the loader bounds the nesting, a hand-built Scene need
    // not, and the order (children in order, each expanded before the next) is the recursive one.
    struct Frame {
        std::uint32_t group;
        Affine3f to_world;
        std::size_t next_child;
    };
    std::vector<Frame> stack{{root, Affine3f::Identity(), 0}};
    while (!stack.empty()) {
        Frame& frame = stack.back();
        const std::vector<Instance>& children = scene.groups[frame.group].children;
        if (frame.next_child == children.size()) {
            stack.pop_back();
            continue;
        }
        const Instance& child = children[frame.next_child++];
        check_index(scene, child);
        const Affine3f child_to_world = frame.to_world * child.transform;
        if (child.kind == Instance::Kind::Mesh) {
            visit(child.index, child_to_world);
        } else {
            if (stack.size() > scene.groups.size()) {
                throw Error(scene.file, "", "group instances form a cycle");
            }
            stack.push_back({child.index, child_to_world, 0});
        }
    }
}

std::uint64_t Scene::instanced_triangle_count() const {
    if (root >= groups.size()) {
        return 0;
    }
    std::vector<std::uint64_t> mesh_triangles;
    mesh_triangles.reserve(meshes.size());
    for (const Mesh& mesh : meshes) {
        mesh_triangles.push_back(mesh.triangle_count());
    }
    return expand_groups(*this, mesh_triangles)[root].triangles;
}

std::vector<GroupExpansion> expand_groups(const Scene& scene,
                                          std::span<const std::uint64_t> mesh_triangles) {
    enum class State : std::uint8_t { New, Open, Done };
    std::vector<State> state(scene.groups.size(), State::New);
    std::vector<GroupExpansion> expansion(scene.groups.size());
    // Post-order with an explicit stack: a group is summed once all the groups it instances are.
    struct Frame {
        std::uint32_t group;
        std::size_t next_child;
    };
    std::vector<Frame> stack;
    for (std::uint32_t start = 0; start < scene.groups.size(); ++start) {
        if (state[start] != State::New) {
            continue;
        }
        state[start] = State::Open;
        stack.push_back({start, 0});
        while (!stack.empty()) {
            Frame& frame = stack.back();
            const std::vector<Instance>& children = scene.groups[frame.group].children;
            if (frame.next_child < children.size()) {
                const Instance& child = children[frame.next_child++];
                check_index(scene, child);
                if (child.kind == Instance::Kind::Group) {
                    if (state[child.index] == State::Open) {
                        throw Error(scene.file, "", "group instances form a cycle");
                    }
                    if (state[child.index] == State::New) {
                        state[child.index] = State::Open;
                        stack.push_back({child.index, 0});
                    }
                }
                continue;
            }
            GroupExpansion& total = expansion[frame.group];
            for (const Instance& child : children) {
                if (child.kind == Instance::Kind::Mesh) {
                    total.instances = saturating_add(total.instances, 1);
                    total.triangles = saturating_add(
                        total.triangles,
                        child.index < mesh_triangles.size() ? mesh_triangles[child.index] : 0);
                } else {
                    const GroupExpansion& below = expansion[child.index];
                    total.levels = std::max(total.levels, saturating_add(below.levels, 1));
                    total.instances = saturating_add(total.instances, below.instances);
                    total.triangles = saturating_add(total.triangles, below.triangles);
                }
            }
            state[frame.group] = State::Done;
            stack.pop_back();
        }
    }
    return expansion;
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
    if (m.cut_out()) {
        os << fmt::format(", opacity_texture={}", m.opacity_texture);
    }
    if (m.texture >= 0 || m.cut_out()) {
        const auto& t = m.uv_transform.matrix();
        os << fmt::format(", uv_transform=[[{}, {}, {}], [{}, {}, {}]]", t(0, 0), t(0, 1), t(0, 2),
                          t(1, 0), t(1, 1), t(1, 2));
    }
    return os << "}";
}

}  // namespace mrt
