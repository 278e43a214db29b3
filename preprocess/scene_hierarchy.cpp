#include "preprocess/scene_hierarchy.h"

#include "common/math/invertibility.h"
#include "common/math/random.h"
#include "common/system/error.h"
#include "common/system/progress.h"
#include "preprocess/octree/build_budget.h"
#include "preprocess/octree/octree_layout.h"
#include "preprocess/octree/surface_prefilter.h"
#include "preprocess/octree/triangle_sampling.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <numeric>
#include <optional>
#include <span>
#include <string>

namespace mrt {

namespace {

/// A node of an instance tree gets points of its own only when its cube is at most this
/// fraction of the cube of its nearest ancestor with points. Its points would otherwise be
/// about as coarse as that ancestor's, so a cone that finds the ancestor's too coarse finds its
/// too; and instances piled on one place, split in halves by count (structure()), would have
/// every level of halves re-sample all the instances below it at the same resolution: N log N
/// work and N·(samples of one instance) memory in every such node. With the cubes shrinking
/// geometrically from one node with points to the next, what an instance costs over all its
/// ancestors is a geometric series, dominated by the finest: linear in the instances.
constexpr float kPointNodeShrink = 0.75f;

/// A group node's prefiltering samples are thinned (every source keeps an evenly spread,
/// area-preserving share) when they would be more than this many layers of surface at the full
/// density through every voxel that gets a point. One layer is what a surface through the
/// node gives; many overlapping instances give one per instance, all landing on the same
/// voxels, where a few hundred samples per point already average the Gaussian to within the
/// 8-bit attributes. This bounds a node's samples by its points, not by its instances.
constexpr double kMaxSampleLayers = 2.0;

/// The box of `box` mapped by `m` (its eight corners), in double: a transformed box may be
/// beyond single precision.
Eigen::AlignedBox3d transformed_box(const Eigen::AlignedBox3f& box, const Affine3f& m) {
    const Eigen::Transform<double, 3, Eigen::Affine> md = m.cast<double>();
    Eigen::AlignedBox3d out;
    for (int c = 0; c < 8; ++c) {
        out.extend(md * box.corner(static_cast<Eigen::AlignedBox3f::CornerType>(c)).cast<double>());
    }
    return out;
}

/// The largest factor by which `m` stretches a length: a finer spacing mapped by it is at most
/// this much longer.
float stretch_of(const Affine3f& m) {
    return Eigen::JacobiSVD<Mat3f>(m.linear()).singularValues()(0);
}

/// A triangle of an instance below a group node, as the node's samples see it.
struct TriangleSource {
    const Mesh& mesh;
    std::uint32_t triangle;
    int level;  ///< Of the mesh node keeping it (with the object, its sample key).
    std::uint32_t object;
    const Affine3f& to_target;  ///< Object space → the group node's space.
    /// The instance of the walk it was reached through, numbered in walk order: with the
    /// object, the key of its samples, so that copies piled on one another sample different
    /// places of their common surface (their thinned samples add up to a denser set).
    std::uint64_t copy;
};

/// Representative points of a finer node below a group node, as its samples see them.
struct PointSource {
    const OctreeNode& node;
    const Affine3f& to_target;  ///< The node's object space → the group node's space.
};

/// Walks what lies below a group node, in the node's space and at the resolution its points
/// need (spacing ≤ half its voxel): the points of the first nodes of each instance's trees
/// whose voxel, stretched by the instance's transform, is at most the spacing, and the
/// triangles the meshes keep above them. Calls visitor.triangle(TriangleSource) and
/// visitor.points(PointSource) for each, in an order fixed by the trees, visitor.visit() for
/// every node and visitor.enter() for every instance (which numbers it).
class SourceWalk {
  public:
    explicit SourceWalk(const SceneHierarchy& hierarchy) : m_hierarchy(hierarchy) {}

    template <class Visitor>
    void node(std::uint32_t o, std::size_t n, const Affine3f& to_target, float stretch,
              float spacing, std::uint64_t copy, Visitor& visitor) const {
        visitor.visit();
        const SceneObject& object = m_hierarchy.objects[o];
        const OctreeNode& node = object.tree.nodes[n];
        const int k = m_hierarchy.options.grid;
        const float voxel = node.side / static_cast<float>(k);
        if (object.kind == SceneObject::Kind::Mesh) {
            // A node's kept triangles are not among the triangles its points stand for.
            for (const std::uint32_t t : node.triangles) {
                visitor.triangle(TriangleSource{*object.mesh, t, node.level, o, to_target, copy});
            }
        }
        if (!node.points.empty() && voxel * stretch <= spacing) {
            visitor.points(PointSource{node, to_target});
            return;
        }
        for (const std::int32_t c : node.children) {
            if (c >= 0) {
                this->node(o, static_cast<std::size_t>(c), to_target, stretch, spacing, copy,
                           visitor);
            }
        }
        for (const std::uint32_t i : node.instances) {
            instance(m_hierarchy.instances[i], to_target, spacing, visitor);
        }
    }

    template <class Visitor>
    void instance(const SceneInstance& instance, const Affine3f& to_target, float spacing,
                  Visitor& visitor) const {
        const Affine3f to_instance_target = to_target * instance.transform;
        node(instance.object, 0, to_instance_target, stretch_of(to_instance_target), spacing,
             visitor.enter(), visitor);
    }

    /// Everything below `node` of group object o's tree, in the node's space.
    template <class Visitor>
    void below(std::uint32_t o, const OctreeNode& node, float spacing, Visitor& visitor) const {
        const Affine3f identity = Affine3f::Identity();
        for (const std::int32_t c : node.children) {
            if (c >= 0) {
                this->node(o, static_cast<std::size_t>(c), identity, 1.0f, spacing, 0, visitor);
            }
        }
        for (const std::uint32_t i : node.instances) {
            instance(m_hierarchy.instances[i], identity, spacing, visitor);
        }
    }

  private:
    const SceneHierarchy& m_hierarchy;
};

/// The voxels of a node's k³ grid that get points: one bit each.
class VoxelSet {
  public:
    explicit VoxelSet(int grid)
        : m_bits((static_cast<std::size_t>(grid) * static_cast<std::size_t>(grid) *
                      static_cast<std::size_t>(grid) +
                  63) /
                 64) {}
    void insert(std::uint32_t v) {
        std::uint64_t& word = m_bits[v / 64];
        const std::uint64_t bit = std::uint64_t{1} << (v % 64);
        m_count += (word & bit) == 0 ? 1 : 0;
        word |= bit;
    }
    std::size_t size() const { return m_count; }
    /// The voxels, ascending.
    std::vector<std::uint32_t> voxels() const {
        std::vector<std::uint32_t> out;
        out.reserve(m_count);
        for (std::size_t w = 0; w < m_bits.size(); ++w) {
            for (std::uint64_t word = m_bits[w]; word != 0; word &= word - 1) {
                out.push_back(static_cast<std::uint32_t>(64 * w) +
                              static_cast<std::uint32_t>(std::countr_zero(word)));
            }
        }
        return out;
    }

  private:
    std::vector<std::uint64_t> m_bits;
    std::size_t m_count = 0;
};

/// How densely a group node samples the triangles below it.
struct TriangleDensity {
    double dense_per_area;     ///< Prefiltering samples per unit of area (node space).
    double choosing_per_area;  ///< Representative-choosing samples per unit of area.
    double per_length;         ///< Samples per unit of a sliver's length.
    double voxel_face;         ///< The node's voxel face, the unit of the samples' areas.
};

/// The samples a group node asks of one triangle: (prefiltering, representative-choosing).
struct TriangleRequest {
    std::uint64_t dense = 0;
    std::uint64_t choosing = 0;
    bool has_area = false;
    std::array<Vec3f, 3> corners;  ///< In the node's space.
};

TriangleRequest request_of(const TriangleSource& source, const TriangleDensity& density) {
    const auto& tri = source.mesh.triangles[source.triangle];
    TriangleRequest r;
    for (int i = 0; i < 3; ++i) {
        r.corners[static_cast<std::size_t>(i)] =
            source.to_target * source.mesh.positions[tri[static_cast<std::size_t>(i)]];
    }
    const double area = triangle_area(r.corners[0], r.corners[1], r.corners[2]);
    const double length = longest_edge(r.corners[0], r.corners[1], r.corners[2]);
    const auto count = [&](double per_area) {
        const double n = std::max({per_area * area, density.per_length * length, 1.0});
        return static_cast<std::uint64_t>(std::min(std::ceil(n), 1e8));
    };
    r.dense = count(density.dense_per_area);
    r.choosing = count(density.choosing_per_area);
    r.has_area = area > 0.0;
    return r;
}

std::uint64_t sample_key(const SceneHierarchy& h, const TriangleSource& source) {
    return triangle_sample_key(
        h.options.seed ^ (0x9e3779b97f4a7c15ull * (source.object + 1)) ^ mix64(source.copy),
        source.triangle, source.level + 64);
}

/// The first pass over a group node's sources: how many samples they ask for, and the voxels
/// that get points — every voxel a source point or a representative-choosing sample lands in
/// (the second pass adds its own samples' voxels).
class SourcePlan {
  public:
    SourcePlan(const SceneHierarchy& h, const OctreeNode& node, const TriangleDensity& density)
        : chosen(h.options.grid), m_h(h), m_node(node), m_density(density) {}

    void visit() { ++visits; }
    std::uint64_t enter() { return ++m_copies; }

    void triangle(const TriangleSource& source) {
        const TriangleRequest r = request_of(source, m_density);
        requested = saturating_add(requested, r.dense);
        if (!r.has_area) {
            return;
        }
        // The same positions as the first of the prefiltering samples (triangle_samples).
        const std::uint64_t key = sample_key(m_h, source);
        for (std::uint64_t i = 0; i < r.choosing; ++i) {
            const Vec2f b =
                triangle_sample(static_cast<std::uint32_t>(i), key, m_h.options.sampling);
            const float b0 = 1.0f - b.x() - b.y();
            const Vec3f p = b0 * r.corners[0] + b.x() * r.corners[1] + b.y() * r.corners[2];
            chosen.insert(voxel_index(m_node, m_h.options.grid, p));
        }
        drawn += r.choosing;
    }

    void points(const PointSource& source) {
        const int k = m_h.options.grid;
        const float voxel = source.node.side / static_cast<float>(k);
        for (const OctreePoint& p : source.node.points) {
            if (p.coverage > 0.0f) {
                chosen.insert(voxel_index(m_node, k,
                                          source.to_target * (source.node.voxel_centre(p.voxel, k) +
                                                              p.offset * voxel * p.normal)));
                requested = saturating_add(requested, 1);
            }
        }
    }

    std::uint64_t requested = 0;  ///< Prefiltering samples asked for, points included.
    std::uint64_t drawn = 0;      ///< Representative-choosing samples drawn.
    std::uint64_t visits = 0;     ///< Nodes walked.
    VoxelSet chosen;              ///< The voxels that get points.

  private:
    const SceneHierarchy& m_h;
    const OctreeNode& m_node;
    const TriangleDensity& m_density;
    std::uint64_t m_copies = 0;
};

/// The second pass: the prefiltering samples, each source's count multiplied by `keep` (≤ 1),
/// at least one per source, and the voxels they land in.
class SourceSamples {
  public:
    SourceSamples(const SceneHierarchy& h, const std::vector<Material>& materials,
                  const TextureSampler* textures, const OctreeNode& node,
                  const TriangleDensity& density, double keep, VoxelSet& chosen)
        : m_h(h),
          m_materials(materials),
          m_textures(textures),
          m_node(node),
          m_density(density),
          m_keep(keep),
          m_chosen(chosen) {}

    void visit() {}
    std::uint64_t enter() { return ++m_copies; }

    void triangle(const TriangleSource& source) {
        const std::size_t count = kept(request_of(source, m_density).dense);
        const std::size_t first = samples.size();
        samples.resize(first + count);
        const std::span<SurfaceSample> out = std::span(samples).subspan(first, count);
        triangle_samples(source.mesh, m_materials, m_textures, source.triangle,
                         sample_key(m_h, source), &source.to_target, m_density.voxel_face, out,
                         m_h.options.sampling);
        for (SurfaceSample& s : out) {
            place(s);
        }
    }

    void points(const PointSource& source) {
        const OctreeNode& node = source.node;
        const int k = m_h.options.grid;
        const float voxel = node.side / static_cast<float>(k);
        const Mat3f linear = source.to_target.linear();
        const Mat3f normal_matrix = inverse_in_double(linear).transpose();
        // Area maps by |det L|·|L⁻ᵀn| for a unit normal n; from the node's voxel faces to
        // this node's. In double: the factors over- or underflow single precision apart.
        const double scale = std::abs(linear.cast<double>().determinant()) *
                             static_cast<double>(voxel) * static_cast<double>(voxel) /
                             m_density.voxel_face;
        std::vector<const OctreePoint*> covering;
        for (const OctreePoint& p : node.points) {
            if (p.coverage > 0.0f) {
                covering.push_back(&p);
            }
        }
        // An evenly strided share of the points, their areas scaled to the node's total.
        const std::size_t count = kept(covering.size());
        double total = 0.0;
        double kept_total = 0.0;
        std::size_t next = 0;
        const std::size_t first = samples.size();
        for (std::size_t j = 0; j < covering.size(); ++j) {
            total += static_cast<double>(covering[j]->coverage);
            if (j != next * covering.size() / count) {
                continue;
            }
            ++next;
            const OctreePoint& p = *covering[j];
            kept_total += static_cast<double>(p.coverage);
            const Vec3f n = normal_matrix * p.normal;
            SurfaceSample s;
            // On the surface, not at the voxel centre (up to √3/2 voxels off it).
            s.position =
                source.to_target * (node.voxel_centre(p.voxel, k) + p.offset * voxel * p.normal);
            s.normal = n.normalized();
            s.normal_length = p.normal_length;
            s.area = static_cast<float>(static_cast<double>(p.coverage) * scale *
                                        n.cast<double>().norm());
            s.diffuse = p.diffuse;
            s.specular = p.specular;
            s.log_phong = std::log(std::max(p.phong_exponent, 1e-3f));
            s.reflectivity = p.reflectivity;
            s.transparency = p.transparency;
            s.roughness = p.roughness;
            s.ior = p.ior;
            s.emission = p.emission;
            s.opacity = p.opacity;
            samples.push_back(s);
        }
        const auto rescale = static_cast<float>(kept_total > 0.0 ? total / kept_total : 1.0);
        for (std::size_t i = first; i < samples.size(); ++i) {
            if (count < covering.size()) {
                samples[i].area *= rescale;
            }
            place(samples[i]);
        }
    }

    std::vector<SurfaceSample> samples;

  private:
    std::size_t kept(std::uint64_t requested) const {
        if (m_keep >= 1.0) {
            return static_cast<std::size_t>(requested);
        }
        return static_cast<std::size_t>(
            std::max(1.0, std::ceil(static_cast<double>(requested) * m_keep)));
    }

    void place(SurfaceSample& s) {
        s.voxel = voxel_index(m_node, m_h.options.grid, s.position);
        if (s.area > 0.0f) {
            m_chosen.insert(s.voxel);
        }
    }

    const SceneHierarchy& m_h;
    const std::vector<Material>& m_materials;
    const TextureSampler* m_textures;
    const OctreeNode& m_node;
    const TriangleDensity& m_density;
    double m_keep;
    VoxelSet& m_chosen;
    std::uint64_t m_copies = 0;
};

/// The work counters of HierarchyWork, added to from parallel nodes.
struct WorkCounters {
    std::atomic<std::uint64_t> samples{0};
    std::atomic<std::uint64_t> visits{0};
    std::atomic<std::uint64_t> point_nodes{0};
    std::atomic<std::uint64_t> thinned_nodes{0};
};

class GroupBuilder {
  public:
    GroupBuilder(const SceneHierarchy& hierarchy, const std::vector<Material>& materials,
                 const TextureSampler* textures, BuildBudget& budget)
        : m_hierarchy(hierarchy),
          m_materials(materials),
          m_textures(textures),
          m_budget(budget),
          m_walk(hierarchy) {}

    /// The nodes of the instance tree over `count` instances from `first` on (instances of
    /// objects built before), without points yet; `where` names the group for refusals.
    PointOctree instance_tree(std::uint32_t first, std::uint32_t count,
                              const std::string& where) const {
        std::vector<Eigen::AlignedBox3d> boxes(count);
        Eigen::AlignedBox3d all;
        for (std::uint32_t i = 0; i < count; ++i) {
            const SceneInstance& instance = m_hierarchy.instances[first + i];
            boxes[i] = transformed_box(m_hierarchy.objects[instance.object].tree.nodes[0].bounds,
                                       instance.transform);
            all.extend(boxes[i]);
        }
        // Every node's cube lies within the root's: checking the root's is enough.
        if (!cube_fits(all)) {
            throw Error(m_budget.file(), where, cube_overflow(all));
        }
        std::vector<std::uint32_t> items(count);
        std::iota(items.begin(), items.end(), 0u);
        PointOctree tree;
        tree.options = m_hierarchy.options;
        tree.nodes = breadth_first(structure(std::move(items), boxes, 0, where));
        for (OctreeNode& node : tree.nodes) {
            for (std::uint32_t& i : node.instances) {
                i += first;
            }
        }
        return tree;
    }

    /// Points for the nodes of object `o`'s tree (`tree`, the object's own, being filled in)
    /// with more than one instance below them and a cube well inside that of their nearest
    /// ancestor with points (kPointNodeShrink), deepest level first (a node's points read its
    /// children's), the nodes of one level in parallel; then the bounds.
    void add_points(std::uint32_t o, PointOctree& tree, const std::string& where) const {
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
        // Parents come before their children (breadth-first).
        std::vector<char> gets_points(count, 0);
        std::vector<float> coarser_side(count, kInfinity);
        for (std::size_t n = 0; n < count; ++n) {
            const OctreeNode& node = tree.nodes[n];
            gets_points[n] =
                below[n] > 1 && (n == 0 || node.side <= kPointNodeShrink * coarser_side[n]);
            for (const std::int32_t c : node.children) {
                if (c >= 0) {
                    coarser_side[static_cast<std::size_t>(c)] =
                        gets_points[n] ? node.side : coarser_side[n];
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
                if (gets_points[n]) {
                    node.points = points_of(o, node, where);
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
                set_bounding_sphere(node);
            });
            end = begin;
        }
    }

    HierarchyWork work() const {
        return {m_work.samples.load(), m_work.visits.load(), m_work.point_nodes.load(),
                m_work.thinned_nodes.load()};
    }

  private:
    std::unique_ptr<OctreeBuildNode> structure(std::vector<std::uint32_t> items,
                                               const std::vector<Eigen::AlignedBox3d>& boxes,
                                               int level, const std::string& where) const {
        auto result = std::make_unique<OctreeBuildNode>();
        OctreeNode& node = result->node;
        node.level = level;
        Eigen::AlignedBox3d bounds;
        for (const std::uint32_t i : items) {
            bounds.extend(boxes[i]);
        }
        node.bounds = bounds.cast<float>();
        std::tie(node.origin, node.side) = bounding_cube(bounds);
        if (items.size() <= kInstancesPerLeaf || level >= m_hierarchy.options.max_depth) {
            std::sort(items.begin(), items.end());
            node.instances = std::move(items);
            return result;
        }
        m_budget.check_level(level + 1, where);
        std::array<std::vector<std::uint32_t>, 8> octants;
        const Vec3d centre =
            node.origin.cast<double>() + Vec3d::Constant(0.5 * static_cast<double>(node.side));
        for (const std::uint32_t i : items) {
            const Vec3d c = boxes[i].center();
            const int octant = (c.x() >= centre.x() ? 1 : 0) | (c.y() >= centre.y() ? 2 : 0) |
                               (c.z() >= centre.z() ? 4 : 0);
            octants[static_cast<std::size_t>(octant)].push_back(i);
        }
        const bool stuck = std::any_of(octants.begin(), octants.end(),
                                       [&](const auto& o) { return o.size() == items.size(); });
        if (stuck) {
            // Instances piled on one point of the cube: halves along the longest axis of their
            // centres (by index where those coincide), so the tree still ends.
            Eigen::AlignedBox3d centres;
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
                result->children[c] = structure(std::move(octants[c]), boxes, level + 1, where);
            }
        }
        return result;
    }

    /// A node's points, from everything below it at no more than half its spacing: a first
    /// pass counts the samples and chooses the voxels, a second draws the samples, thinned
    /// when they would be more than kMaxSampleLayers layers of surface.
    std::vector<OctreePoint> points_of(std::uint32_t o, const OctreeNode& node,
                                       const std::string& where) const {
        const int k = m_hierarchy.options.grid;
        const float spacing = 0.5f * node.side / static_cast<float>(k);
        const double s = static_cast<double>(spacing);
        const double voxel = static_cast<double>(node.side) / k;
        // Dense enough to prefilter (c per voxel face, the paper's density, as a mesh node
        // samples the triangles it passes down), to choose representatives (4 per face of the
        // spacing: each surface point within half a spacing of a sample) and for a sliver's
        // length (one per half spacing).
        const double dense = static_cast<double>(std::max(m_hierarchy.options.oversampling, 4));
        const TriangleDensity density{dense / (voxel * voxel), 4.0 / (s * s), 2.0 / s,
                                      voxel * voxel};

        SourcePlan plan(m_hierarchy, node, density);
        m_walk.below(o, node, spacing, plan);
        // One layer of surface at the full density puts `dense` samples in a voxel.
        const double allowed = kMaxSampleLayers * dense *
                               static_cast<double>(std::max<std::size_t>(plan.chosen.size(), 1));
        const double keep = static_cast<double>(plan.requested) > allowed
                                ? allowed / static_cast<double>(plan.requested)
                                : 1.0;

        SourceSamples draw(m_hierarchy, m_materials, m_textures, node, density, keep, plan.chosen);
        m_walk.below(o, node, spacing, draw);
        m_work.samples += plan.drawn + draw.samples.size();
        m_work.visits += plan.visits;
        m_work.point_nodes += 1;
        m_work.thinned_nodes += keep < 1.0 ? 1 : 0;
        if (plan.chosen.size() == 0) {
            return {};
        }
        m_budget.add_points(plan.chosen.size(), where);
        return prefilter_points(node, k, draw.samples, plan.chosen.voxels());
    }

    const SceneHierarchy& m_hierarchy;
    const std::vector<Material>& m_materials;
    const TextureSampler* m_textures;
    BuildBudget& m_budget;
    SourceWalk m_walk;
    mutable WorkCounters m_work;
};

}  // namespace

std::uint64_t hierarchy_progress_total(const Scene& scene, Instancing instancing) {
    if (instancing == Instancing::Flatten) {
        return scene.instanced_triangle_count();
    }
    std::uint64_t total = scene.unique_triangle_count();
    for (const Group& group : scene.groups) {
        total += group.children.size();
    }
    return total;
}

SceneHierarchy build_scene_hierarchy(const Scene& scene, const TextureSampler* textures,
                                     const PointOctreeOptions& options, Instancing instancing,
                                     Progress* progress) {
    SceneHierarchy h;
    h.options = options;
    BuildBudget budget(options.budgets, scene.file);
    if (instancing == Instancing::Flatten) {
        auto world = std::make_unique<Mesh>(mrt::flatten(scene));
        if (world->triangles.empty()) {
            throw Error(scene.file, "", "the scene has no triangles to build a hierarchy of");
        }
        SceneObject object;
        object.kind = SceneObject::Kind::Mesh;
        object.mesh = world.get();
        object.tree =
            build_point_octree(*world, scene.materials, textures, options, budget, progress);
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
            build_point_octree(*object.mesh, scene.materials, textures, options, budget, progress);
    });

    std::vector<std::optional<std::uint32_t>> group_object(scene.groups.size());
    const GroupBuilder builder(h, scene.materials, textures, budget);
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
        const std::string where = "group '" + scene.groups[g].name + "'";
        SceneObject object;
        object.kind = SceneObject::Kind::Group;
        object.tree = builder.instance_tree(first, static_cast<std::uint32_t>(items.size()), where);
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
        // The source walk reads the finished levels of this tree through the hierarchy.
        builder.add_points(o, h.objects[o].tree, where);
        if (progress != nullptr) {
            progress->advance(scene.groups[g].children.size());
        }
    }
    if (!group_object[scene.root]) {
        throw Error(scene.file, "", "the scene has no triangles to build a hierarchy of");
    }
    h.world = *group_object[scene.root];
    h.work = builder.work();
    return h;
}

}  // namespace mrt
