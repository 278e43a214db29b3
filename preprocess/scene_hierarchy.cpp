#include "preprocess/scene_hierarchy.h"

#include "common/error.h"
#include "common/progress.h"
#include "preprocess/octree_layout.h"
#include "preprocess/surface_prefilter.h"
#include "preprocess/triangle_sampling.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>

namespace mrt {

namespace {

/// The box of `box` mapped by `m` (its eight corners).
Eigen::AlignedBox3f transformed_box(const Eigen::AlignedBox3f& box, const Affine3f& m) {
    Eigen::AlignedBox3f out;
    for (int c = 0; c < 8; ++c) {
        out.extend(m * box.corner(static_cast<Eigen::AlignedBox3f::CornerType>(c)));
    }
    return out;
}

/// The largest factor by which `m` stretches a length: a finer spacing mapped by it is at most
/// this much longer.
float stretch_of(const Affine3f& m) {
    return Eigen::JacobiSVD<Mat3f>(m.linear()).singularValues()(0);
}

/// The points of `node` as samples placed by `to_target` (node's object space → target space).
void append_point_samples(const OctreeNode& node, int grid, const Affine3f& to_target,
                          std::vector<SurfaceSample>& out) {
    const float voxel = node.side / static_cast<float>(grid);
    const Mat3f linear = to_target.linear();
    const Mat3f normal_matrix = linear.inverse().transpose();
    const float det = std::abs(linear.determinant());
    for (const OctreePoint& p : node.points) {
        if (!(p.coverage > 0.0f)) {
            continue;
        }
        const Vec3f n = normal_matrix * p.normal;
        SurfaceSample s;
        // On the surface, not at the voxel centre (up to √3/2 voxels off it).
        s.position = to_target * (node.voxel_centre(p.voxel, grid) + p.offset * voxel * p.normal);
        s.normal = n.normalized();
        // Area maps by |det L|·|L⁻ᵀn| for a unit normal n.
        s.area = p.coverage * voxel * voxel * det * n.norm();
        s.diffuse = p.diffuse;
        s.specular = p.specular;
        s.log_phong = std::log(std::max(p.phong_exponent, 1e-3f));
        s.reflectivity = p.reflectivity;
        s.transparency = p.transparency;
        s.roughness = p.roughness;
        s.ior = p.ior;
        out.push_back(s);
    }
}

/// Gathers, in a group node's space, the finest-enough representation of what lies below it.
class Collector {
  public:
    Collector(const SceneHierarchy& hierarchy, const std::vector<Material>& materials,
              const TextureSampler* textures)
        : m_hierarchy(hierarchy), m_materials(materials), m_textures(textures) {}

    /// Samples of object `o` placed by `to_target`, from nodes of spacing ≤ `spacing` (or the
    /// triangles), appended to `out`.
    void object(std::uint32_t o, const Affine3f& to_target, float spacing,
                std::vector<SurfaceSample>& out) const {
        node(o, 0, to_target, stretch_of(to_target), spacing, out);
    }

    void node(std::uint32_t o, std::size_t n, const Affine3f& to_target, float stretch,
              float spacing, std::vector<SurfaceSample>& out) const {
        const SceneObject& object = m_hierarchy.objects[o];
        const OctreeNode& node = object.tree.nodes[n];
        const int k = m_hierarchy.options.grid;
        const float voxel = node.side / static_cast<float>(k);
        if (object.kind == SceneObject::Kind::Mesh) {
            // A node's kept triangles are not among the triangles its points stand for.
            for (const std::uint32_t t : node.triangles) {
                triangle(*object.mesh, t, node.level, o, to_target, spacing, out);
            }
        }
        if (!node.points.empty() && voxel * stretch <= spacing) {
            append_point_samples(node, k, to_target, out);
            return;
        }
        for (const std::int32_t c : node.children) {
            if (c >= 0) {
                this->node(o, static_cast<std::size_t>(c), to_target, stretch, spacing, out);
            }
        }
        for (const std::uint32_t i : node.instances) {
            const SceneInstance& instance = m_hierarchy.instances[i];
            object_of(instance, to_target, spacing, out);
        }
    }

    void object_of(const SceneInstance& instance, const Affine3f& to_target, float spacing,
                   std::vector<SurfaceSample>& out) const {
        object(instance.object, to_target * instance.transform, spacing, out);
    }

  private:
    void triangle(const Mesh& mesh, std::uint32_t t, int level, std::uint32_t o,
                  const Affine3f& to_target, float spacing, std::vector<SurfaceSample>& out) const {
        const auto& tri = mesh.triangles[t];
        const Vec3f a = to_target * mesh.positions[tri[0]];
        const Vec3f b = to_target * mesh.positions[tri[1]];
        const Vec3f c = to_target * mesh.positions[tri[2]];
        const float area = 0.5f * (b - a).cross(c - a).norm();
        const float longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
        // Dense enough to prefilter (c per voxel face), to choose representatives (4 per voxel
        // face, as the mesh octrees do) and for a sliver's length (one per half voxel).
        const float density =
            std::max({static_cast<float>(std::max(m_hierarchy.options.oversampling, 4)) * area /
                          (spacing * spacing),
                      2.0f * longest / spacing, 1.0f});
        const auto count = static_cast<std::size_t>(std::min(std::ceil(density), 1e8f));
        const std::size_t first = out.size();
        out.resize(first + count);
        const std::uint64_t key = triangle_sample_key(
            m_hierarchy.options.seed ^ (0x9e3779b97f4a7c15ull * (o + 1)), t, level + 64);
        triangle_samples(mesh, m_materials, m_textures, t, key, &to_target,
                         std::span(out).subspan(first, count), m_hierarchy.options.sampling);
    }

    const SceneHierarchy& m_hierarchy;
    const std::vector<Material>& m_materials;
    const TextureSampler* m_textures;
};

class GroupBuilder {
  public:
    GroupBuilder(const SceneHierarchy& hierarchy, const std::vector<Material>& materials,
                 const TextureSampler* textures)
        : m_hierarchy(hierarchy), m_collector(hierarchy, materials, textures) {}

    /// The nodes of the instance tree over `items` (instances of objects built before),
    /// without points yet.
    PointOctree instance_tree(std::vector<std::uint32_t> items) const {
        std::vector<Eigen::AlignedBox3f> boxes(m_hierarchy.instances.size());
        for (const std::uint32_t i : items) {
            const SceneInstance& instance = m_hierarchy.instances[i];
            boxes[i] = transformed_box(m_hierarchy.objects[instance.object].tree.nodes[0].bounds,
                                       instance.transform);
        }
        PointOctree tree;
        tree.options = m_hierarchy.options;
        tree.nodes = breadth_first(structure(std::move(items), boxes, 0));
        return tree;
    }

    /// Points for every node of object `o`'s tree (`tree`, the object's own, being filled in)
    /// with more than one instance below it, deepest level first (a node's points read its
    /// children's), the nodes of one level in parallel; then the bounds.
    void add_points(std::uint32_t o, PointOctree& tree) const {
        const std::size_t count = tree.nodes.size();
        std::vector<std::size_t> below(count, 0);
        for (std::size_t n = count; n-- > 0;) {
            below[n] = tree.nodes[n].instances.size();
            for (const std::int32_t c : tree.nodes[n].children) {
                if (c >= 0) {
                    below[n] += below[static_cast<std::size_t>(c)];
                }
            }
        }
        const int k = m_hierarchy.options.grid;
        std::size_t end = count;
        while (end > 0) {
            const int level = tree.nodes[end - 1].level;
            std::size_t begin = end;
            while (begin > 0 && tree.nodes[begin - 1].level == level) {
                --begin;
            }
            tbb::parallel_for(begin, end, [&](std::size_t n) {
                OctreeNode& node = tree.nodes[n];
                if (below[n] > 1) {
                    node.points = points_of(o, node);
                }
                const Vec3f half_voxel = Vec3f::Constant(0.5f * node.side / static_cast<float>(k));
                for (const OctreePoint& p : node.points) {
                    const Vec3f c = node.voxel_centre(p.voxel, k);
                    node.bounds.extend(c - half_voxel);
                    node.bounds.extend(c + half_voxel);
                }
                for (const std::int32_t c : node.children) {
                    if (c >= 0) {
                        node.bounds.extend(tree.nodes[static_cast<std::size_t>(c)].bounds);
                    }
                }
                node.sphere_centre = node.bounds.center();
                node.sphere_radius = 0.5f * node.bounds.sizes().norm();
            });
            end = begin;
        }
    }

  private:
    std::unique_ptr<OctreeBuildNode> structure(std::vector<std::uint32_t> items,
                                               const std::vector<Eigen::AlignedBox3f>& boxes,
                                               int level) const {
        auto result = std::make_unique<OctreeBuildNode>();
        OctreeNode& node = result->node;
        node.level = level;
        for (const std::uint32_t i : items) {
            node.bounds.extend(boxes[i]);
        }
        std::tie(node.origin, node.side) = bounding_cube(node.bounds);
        if (items.size() <= kInstancesPerLeaf || level >= m_hierarchy.options.max_depth) {
            std::sort(items.begin(), items.end());
            node.instances = std::move(items);
            return result;
        }
        std::array<std::vector<std::uint32_t>, 8> octants;
        const Vec3f centre = node.origin + Vec3f::Constant(0.5f * node.side);
        for (const std::uint32_t i : items) {
            const Vec3f c = boxes[i].center();
            const int octant = (c.x() >= centre.x() ? 1 : 0) | (c.y() >= centre.y() ? 2 : 0) |
                               (c.z() >= centre.z() ? 4 : 0);
            octants[static_cast<std::size_t>(octant)].push_back(i);
        }
        const bool stuck = std::any_of(octants.begin(), octants.end(),
                                       [&](const auto& o) { return o.size() == items.size(); });
        if (stuck) {
            // Instances piled on one point of the cube: halves along the longest axis of their
            // centres (by index where those coincide), so the tree still ends.
            Eigen::AlignedBox3f centres;
            for (const std::uint32_t i : items) {
                centres.extend(boxes[i].center());
            }
            int axis = 0;
            centres.sizes().maxCoeff(&axis);
            std::stable_sort(items.begin(), items.end(), [&](std::uint32_t a, std::uint32_t b) {
                return boxes[a].center()[axis] < boxes[b].center()[axis];
            });
            const auto half = static_cast<std::ptrdiff_t>(items.size() / 2);
            octants = {};
            octants[0].assign(items.begin(), items.begin() + half);
            octants[1].assign(items.begin() + half, items.end());
        }
        for (std::size_t c = 0; c < 8; ++c) {
            if (!octants[c].empty()) {
                result->children[c] = structure(std::move(octants[c]), boxes, level + 1);
            }
        }
        return result;
    }

    /// A node's points, from everything below it at no more than half its spacing.
    std::vector<OctreePoint> points_of(std::uint32_t o, const OctreeNode& node) const {
        const int k = m_hierarchy.options.grid;
        const float spacing = 0.5f * node.side / static_cast<float>(k);
        std::vector<SurfaceSample> samples;
        for (const std::int32_t c : node.children) {
            if (c >= 0) {
                m_collector.node(o, static_cast<std::size_t>(c), Affine3f::Identity(), 1.0f,
                                 spacing, samples);
            }
        }
        for (const std::uint32_t i : node.instances) {
            m_collector.object_of(m_hierarchy.instances[i], Affine3f::Identity(), spacing, samples);
        }
        std::vector<std::uint32_t> chosen;
        chosen.reserve(samples.size());
        for (SurfaceSample& s : samples) {
            s.voxel = voxel_index(node, k, s.position);
            if (s.area > 0.0f) {
                chosen.push_back(s.voxel);
            }
        }
        if (chosen.empty()) {
            return {};
        }
        return prefilter_points(node, k, samples, std::move(chosen));
    }

    const SceneHierarchy& m_hierarchy;
    Collector m_collector;
};

}  // namespace

std::uint64_t hierarchy_progress_total(const Scene& scene, bool flatten) {
    if (flatten) {
        return scene.instanced_triangle_count();
    }
    std::uint64_t total = scene.unique_triangle_count();
    for (const Group& group : scene.groups) {
        total += group.children.size();
    }
    return total;
}

SceneHierarchy build_scene_hierarchy(const Scene& scene, const TextureSampler* textures,
                                     const PointOctreeOptions& options, bool flatten,
                                     Progress* progress) {
    SceneHierarchy h;
    h.options = options;
    if (flatten) {
        auto world = std::make_unique<Mesh>(mrt::flatten(scene));
        if (world->triangles.empty()) {
            throw Error(scene.file, "", "the scene has no triangles to build a hierarchy of");
        }
        SceneObject object;
        object.kind = SceneObject::Kind::Mesh;
        object.mesh = world.get();
        object.tree = build_point_octree(*world, scene.materials, textures, options, progress);
        h.flattened = std::move(world);
        h.objects.push_back(std::move(object));
        h.world = 0;
        return h;
    }
    if (scene.root >= scene.groups.size()) {
        throw Error(scene.file, "", "the scene has no world group");
    }
    // Objects in dependency order: the meshes, then groups after every group they instance.
    // Empty meshes and groups get no object; instances of them are dropped.
    std::vector<std::optional<std::uint32_t>> mesh_object(scene.meshes.size());
    std::vector<char> mesh_used(scene.meshes.size(), 0);
    std::vector<std::uint32_t> group_order;
    std::vector<char> group_state(scene.groups.size(), 0);  // 0 new, 1 open, 2 done
    const auto visit = [&](auto&& self, std::uint32_t g) -> void {
        if (group_state[g] == 2) {
            return;
        }
        if (group_state[g] == 1) {
            throw Error(scene.file, "", "group instances form a cycle");
        }
        group_state[g] = 1;
        for (const Instance& child : scene.groups[g].children) {
            if (child.kind == Instance::Kind::Group) {
                self(self, child.index);
            } else {
                mesh_used[child.index] = 1;
            }
        }
        group_state[g] = 2;
        group_order.push_back(g);
    };
    visit(visit, scene.root);

    std::vector<std::uint32_t> mesh_indices;
    for (std::uint32_t m = 0; m < scene.meshes.size(); ++m) {
        if (mesh_used[m] && !scene.meshes[m].triangles.empty()) {
            mesh_object[m] = static_cast<std::uint32_t>(h.objects.size());
            SceneObject object;
            object.kind = SceneObject::Kind::Mesh;
            object.mesh = &scene.meshes[m];
            h.objects.push_back(std::move(object));
            mesh_indices.push_back(m);
        }
    }
    tbb::parallel_for(std::size_t{0}, mesh_indices.size(), [&](std::size_t i) {
        SceneObject& object = h.objects[*mesh_object[mesh_indices[i]]];
        object.tree =
            build_point_octree(*object.mesh, scene.materials, textures, options, progress);
    });

    std::vector<std::optional<std::uint32_t>> group_object(scene.groups.size());
    const GroupBuilder builder(h, scene.materials, textures);
    for (const std::uint32_t g : group_order) {
        std::vector<std::uint32_t> items;
        for (const Instance& child : scene.groups[g].children) {
            const std::optional<std::uint32_t> o = child.kind == Instance::Kind::Mesh
                                                       ? mesh_object[child.index]
                                                       : group_object[child.index];
            if (o) {
                items.push_back(static_cast<std::uint32_t>(h.instances.size()));
                h.instances.push_back({*o, child.transform});
            }
        }
        if (items.empty()) {
            continue;
        }
        const std::uint32_t first = items.front();
        SceneObject object;
        object.kind = SceneObject::Kind::Group;
        object.tree = builder.instance_tree(std::move(items));
        // Renumber the group's instances in node order, so each node's are consecutive (the
        // file stores a range per node); nothing refers to them by number yet.
        const std::vector<SceneInstance> built(h.instances.begin() + first, h.instances.end());
        std::uint32_t next = first;
        for (OctreeNode& node : object.tree.nodes) {
            for (std::uint32_t& i : node.instances) {
                h.instances[next] = built[i - first];
                i = next++;
            }
        }
        const auto o = static_cast<std::uint32_t>(h.objects.size());
        group_object[g] = o;
        h.objects.push_back(std::move(object));
        // The collector reads the finished levels of this tree through the hierarchy.
        builder.add_points(o, h.objects[o].tree);
        if (progress != nullptr) {
            progress->advance(scene.groups[g].children.size());
        }
    }
    if (!group_object[scene.root]) {
        throw Error(scene.file, "", "the scene has no triangles to build a hierarchy of");
    }
    h.world = *group_object[scene.root];
    return h;
}

}  // namespace mrt
