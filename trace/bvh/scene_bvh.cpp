#include "trace/bvh/scene_bvh.h"

#include "common/math/invertibility.h"
#include "common/system/error.h"
#include "trace/bvh/bvh_build.h"
#include "trace/bvh/cutouts.h"
#include "trace/bvh/triangle_intersect.h"

#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <ostream>
#include <string>

namespace mrt {
namespace {

/// Groups nest at most this deep (root = 1), which bounds the traversal's recursion. The scene
/// loader refuses deeper scenes (the group-nesting budget); this guards hand-built ones.
constexpr int kMaxGroupNesting = static_cast<int>(kMaxSupportedGroupNesting);

/// Instances are expensive primitives (a ray transform and a whole BVH), so group BVHs end in
/// single-instance leaves.
constexpr BvhBuildOptions kGroupBuildOptions{1, 1, 1.0f, 4.0f};

struct InstanceRecord {
    Affine3f to_parent = Affine3f::Identity();  ///< Child space → group space.
    Affine3f to_child = Affine3f::Identity();   ///< Its inverse, for rays.
    Instance::Kind kind = Instance::Kind::Mesh;
    std::uint32_t index = 0;
    bool identity = true;  ///< Exactly the identity: rays pass unchanged.
};

struct GroupRecord {
    std::vector<BinaryBvhNode> nodes;       ///< Over the instances' boxes in group space.
    std::vector<InstanceRecord> instances;  ///< Leaf order.
    Eigen::AlignedBox3f bounds;             ///< In group space; empty when nothing hittable.
};

/// The chain of instances from the current one up to the root, on the C++ stack.
struct PathLink {
    const InstanceRecord* instance;
    const PathLink* parent;
};

/// The padding of a transformed box, in float epsilons of the largest coordinate involved: the
/// transform's rounding of a corner and of the geometry's own points is a few ulps each, so 64
/// covers both with room and costs a negligible widening.
constexpr float kBoxPadUlps = 64.0f;

/// Box around the 8 transformed corners, padded so that rounding in the transform (a few ulps
/// of the coordinates involved) cannot make it smaller than the transformed geometry.
Eigen::AlignedBox3f transform_box(const Eigen::AlignedBox3f& box, const Affine3f& xf) {
    Eigen::AlignedBox3f out;
    out.setEmpty();
    for (int corner = 0; corner < 8; ++corner) {
        const Vec3f p((corner & 1) != 0 ? box.max().x() : box.min().x(),
                      (corner & 2) != 0 ? box.max().y() : box.min().y(),
                      (corner & 4) != 0 ? box.max().z() : box.min().z());
        out.extend(xf * p);
    }
    const float magnitude =
        std::max(out.min().cwiseAbs().maxCoeff(), out.max().cwiseAbs().maxCoeff()) +
        xf.translation().cwiseAbs().maxCoeff();
    const Vec3f pad =
        Vec3f::Constant(kBoxPadUlps * std::numeric_limits<float>::epsilon() * magnitude);
    return Eigen::AlignedBox3f(out.min() - pad, out.max() + pad);
}

Ray to_child_space(const Ray& ray, const InstanceRecord& instance) {
    // The direction keeps its scale, so t measures the same point in both spaces.
    return Ray{instance.to_child * ray.origin, instance.to_child.linear() * ray.direction,
               ray.t_max};
}

}  // namespace

struct SceneBvh::Impl {
    std::vector<TriangleBvh> meshes;
    std::vector<GroupRecord> groups;
    std::uint32_t root = 0;
    bool empty = true;

    struct Closest {
        SceneHit* hit;
        float t_best;
        const SceneCutouts* cutouts;
        bool found = false;
    };

    void build_group(const Scene& scene, std::uint32_t g);

    /// Intersects the subtree of group `g` (ray in the group's space); for any-hit queries
    /// returns true as soon as something is hit.
    template <bool kAnyHit>
    bool traverse(std::uint32_t g, const Ray& ray, const PathLink* path, Closest& state) const;
    /// One child instance: transforms the ray, descends; true only for an any-hit success.
    template <bool kAnyHit>
    bool visit(const InstanceRecord& instance, const Ray& ray, const PathLink* path,
               Closest& state) const;
};

void SceneBvh::Impl::build_group(const Scene& scene, std::uint32_t g) {
    GroupRecord& record = groups[g];
    std::vector<Eigen::AlignedBox3f> boxes;
    std::vector<InstanceRecord> instances;
    record.bounds.setEmpty();
    for (const Instance& child : scene.groups[g].children) {
        const Eigen::AlignedBox3f child_bounds = child.kind == Instance::Kind::Mesh
                                                     ? meshes[child.index].bounds()
                                                     : groups[child.index].bounds;
        if (child_bounds.isEmpty()) {
            continue;  // Nothing there to hit.
        }
        InstanceRecord instance;
        instance.kind = child.kind;
        instance.index = child.index;
        instance.to_parent = child.transform;
        instance.identity = child.transform.matrix() == Mat4f::Identity();
        if (!instance.identity) {
            instance.to_child = inverse_in_double(child.transform);
            if (!instance.to_child.matrix().allFinite()) {
                continue;  // Singular (flattened to zero volume): no ray can hit it sensibly.
            }
        }
        const Eigen::AlignedBox3f box =
            instance.identity ? child_bounds : transform_box(child_bounds, instance.to_parent);
        if (!box.min().allFinite() || !box.max().allFinite()) {
            continue;
        }
        boxes.push_back(box);
        instances.push_back(instance);
        record.bounds.extend(box);
    }
    BvhBuildResult built = build_bvh(boxes, kGroupBuildOptions);
    record.nodes = std::move(built.nodes);
    record.instances.reserve(instances.size());
    for (const std::uint32_t i : built.primitive_order) {
        record.instances.push_back(instances[i]);
    }
}

SceneBvh::SceneBvh(const Scene& scene) : m_impl(std::make_unique<Impl>()) {
    const auto start = std::chrono::steady_clock::now();
    Impl& impl = *m_impl;

    // Validate the hierarchy before any work: indices in range, no cycles, bounded nesting.
    // Groups come out in post-order (children before parents) for the bottom-up build.
    std::vector<std::uint32_t> post_order;
    if (!scene.groups.empty()) {
        if (scene.root >= scene.groups.size()) {
            throw Error(scene.file, "",
                        "root group " + std::to_string(scene.root) + " out of range (" +
                            std::to_string(scene.groups.size()) + " groups)");
        }
        enum class Mark : std::uint8_t { New, Active, Done };
        std::vector<Mark> marks(scene.groups.size(), Mark::New);
        // Height of each group's subtree (a leaf group is 1); the root's must stay within the
        // limit. The depth check stops runaway chains before the recursion gets deep itself.
        std::vector<int> heights(scene.groups.size(), 0);
        const auto too_deep = [&](std::uint32_t g) {
            return Error(scene.file, "group '" + scene.groups[g].name + "'",
                         "groups nest deeper than " + std::to_string(kMaxGroupNesting) + " levels");
        };
        const auto visit = [&](const auto& self, std::uint32_t g, int depth) -> void {
            if (depth > kMaxGroupNesting) {
                throw too_deep(g);
            }
            marks[g] = Mark::Active;
            int height = 1;
            for (const Instance& child : scene.groups[g].children) {
                const std::size_t limit =
                    child.kind == Instance::Kind::Mesh ? scene.meshes.size() : scene.groups.size();
                if (child.index >= limit) {
                    throw Error(scene.file, "group '" + scene.groups[g].name + "'",
                                std::string(child.kind == Instance::Kind::Mesh ? "mesh" : "group") +
                                    " index " + std::to_string(child.index) + " out of range");
                }
                if (child.kind == Instance::Kind::Group) {
                    if (marks[child.index] == Mark::Active) {
                        throw Error(scene.file, "group '" + scene.groups[g].name + "'",
                                    "instances group '" + scene.groups[child.index].name +
                                        "' which contains it (cycle)");
                    }
                    if (marks[child.index] == Mark::New) {
                        self(self, child.index, depth + 1);
                    }
                    height = std::max(height, heights[child.index] + 1);
                }
            }
            if (height > kMaxGroupNesting) {
                throw too_deep(g);
            }
            heights[g] = height;
            marks[g] = Mark::Done;
            post_order.push_back(g);
        };
        visit(visit, scene.root, 1);
    }

    impl.meshes.resize(scene.meshes.size());
    tbb::parallel_for(std::size_t{0}, scene.meshes.size(),
                      [&](std::size_t i) { impl.meshes[i] = TriangleBvh(scene.meshes[i]); });
    impl.groups.resize(scene.groups.size());
    for (const std::uint32_t g : post_order) {
        impl.build_group(scene, g);
    }
    impl.root = scene.root;
    impl.empty = post_order.empty() || impl.groups[scene.root].nodes.empty();

    for (const TriangleBvh& bvh : impl.meshes) {
        m_stats.mesh_nodes += bvh.nodes().size();
        m_stats.bytes += bvh.bytes();
    }
    m_stats.unique_triangles = scene.unique_triangle_count();
    for (const GroupRecord& group : impl.groups) {
        m_stats.group_nodes += group.nodes.size();
        m_stats.bytes += sizeof(GroupRecord) + group.nodes.capacity() * sizeof(BinaryBvhNode) +
                         group.instances.capacity() * sizeof(InstanceRecord);
    }
    m_stats.bytes += sizeof(Impl);
    m_stats.build_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

SceneBvh::~SceneBvh() = default;
SceneBvh::SceneBvh(SceneBvh&&) noexcept = default;
SceneBvh& SceneBvh::operator=(SceneBvh&&) noexcept = default;

template <bool kAnyHit>
bool SceneBvh::Impl::visit(const InstanceRecord& instance, const Ray& ray, const PathLink* path,
                           Closest& state) const {
    const Ray local = instance.identity ? ray : to_child_space(ray, instance);
    const PathLink link{&instance, path};
    if (instance.kind == Instance::Kind::Group) {
        return traverse<kAnyHit>(instance.index, local, &link, state) && kAnyHit;
    }
    const MeshCutout* cutout =
        state.cutouts != nullptr ? state.cutouts->of_mesh(instance.index) : nullptr;
    if constexpr (kAnyHit) {
        return meshes[instance.index].occluded(local, cutout);
    } else {
        TriangleHit tri;
        tri.t = state.t_best;  // Index 0: a tie with a hit in another mesh keeps that one.
        if (meshes[instance.index].intersect(local, tri, cutout)) {
            state.t_best = tri.t;
            state.found = true;
            SceneHit& hit = *state.hit;
            hit.t = tri.t;
            hit.mesh = instance.index;
            hit.triangle = tri.triangle;
            hit.b1 = tri.b1;
            hit.b2 = tri.b2;
            // The product of the path's transforms, only for hits (most instances a ray visits
            // are not hit closer).
            Affine3f to_world = Affine3f::Identity();
            for (const PathLink* p = &link; p != nullptr; p = p->parent) {
                if (!p->instance->identity) {
                    to_world = p->instance->to_parent * to_world;
                }
            }
            hit.object_to_world = Affine3fCompact(to_world.matrix().topRows<3>());
        }
        return false;
    }
}

template <bool kAnyHit>
bool SceneBvh::Impl::traverse(std::uint32_t g, const Ray& ray, const PathLink* path,
                              Closest& state) const {
    // Never empty here: groups with nothing hittable have empty bounds, so their parents leave
    // them out, and intersect() checks the root.
    const GroupRecord& group = groups[g];
    if (group.nodes.size() == 1) {
        // A single child (a scene that is one mesh, say): its own BVH culls the ray, so the
        // group's box test and ray setup would be pure overhead.
        return visit<kAnyHit>(group.instances[0], ray, path, state) || (!kAnyHit && state.found);
    }
    const SlabRay slab(ray);
    std::uint32_t stack[kBvhMaxDepth];
    int top = 0;
    std::uint32_t current = 0;
    for (;;) {
        const BinaryBvhNode& node = group.nodes[current];
        float t_near = 0.0f;
        float t_far = state.t_best;
        if (box_interval(slab, node.lower, node.upper, t_near, t_far)) {
            if (node.count == 0) {
                // Front to back along the split axis.
                const bool second_first = ray.direction[node.axis] < 0.0f;
                stack[top++] = second_first ? current + 1 : node.offset;
                current = second_first ? node.offset : current + 1;
                continue;
            }
            if (visit<kAnyHit>(group.instances[node.offset], ray, path, state)) {
                return true;
            }
        }
        if (top == 0) {
            return state.found;
        }
        current = stack[--top];
    }
}

bool SceneBvh::intersect(const Ray& ray, SceneHit& hit, const SceneCutouts* cutouts) const {
    if (m_impl->empty) {
        return false;
    }
    Impl::Closest state{&hit, ray.t_max, cutouts};
    return m_impl->traverse<false>(m_impl->root, ray, nullptr, state);
}

bool SceneBvh::occluded(const Ray& ray, const SceneCutouts* cutouts) const {
    if (m_impl->empty) {
        return false;
    }
    Impl::Closest state{nullptr, ray.t_max, cutouts};
    return m_impl->traverse<true>(m_impl->root, ray, nullptr, state);
}

Eigen::AlignedBox3f SceneBvh::bounds() const {
    if (m_impl->empty) {
        Eigen::AlignedBox3f box;
        box.setEmpty();
        return box;
    }
    return m_impl->groups[m_impl->root].bounds;
}

std::ostream& operator<<(std::ostream& os, const SceneBvhStats& s) {
    return print_fields(os, "SceneBvhStats", s);
}

}  // namespace mrt
