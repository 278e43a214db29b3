#include "preprocess/octree/point_octree.h"

#include "common/system/error.h"
#include "common/system/progress.h"
#include "common/texture/texture.h"
#include "preprocess/octree/build_budget.h"
#include "preprocess/octree/octree_layout.h"
#include "preprocess/octree/surface_prefilter.h"
#include "preprocess/octree/triangle_sampling.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>

namespace mrt {

namespace {

/// Samples per voxel face of area that choose the representatives. At 4 the R2 points on a
/// triangle are about half a voxel apart, so every point of the surface is within half a
/// voxel of a sample and within the voxel diagonal of that sample's voxel centre.
constexpr float kRepresentativeDensity = 4.0f;

/// The bounding box of triangles `tris` of `mesh`, in double.
Eigen::AlignedBox3d triangle_box(const Mesh& mesh, const std::vector<std::uint32_t>& tris) {
    Eigen::AlignedBox3d box;
    for (const std::uint32_t t : tris) {
        for (const std::uint32_t v : mesh.triangles[t]) {
            box.extend(mesh.positions[v].cast<double>());
        }
    }
    return box;
}

/// The bounding cube of triangles `tris` of `mesh`.
std::pair<Vec3f, float> bounding_cube(const Mesh& mesh, const std::vector<std::uint32_t>& tris) {
    return mrt::bounding_cube(triangle_box(mesh, tris));
}

double triangle_area(const Mesh& mesh, std::uint32_t t) {
    const auto& tri = mesh.triangles[t];
    return mrt::triangle_area(mesh.positions[tri[0]], mesh.positions[tri[1]],
                              mesh.positions[tri[2]]);
}

double longest_edge(const Mesh& mesh, std::uint32_t t) {
    const auto& tri = mesh.triangles[t];
    return mrt::longest_edge(mesh.positions[tri[0]], mesh.positions[tri[1]],
                             mesh.positions[tri[2]]);
}

class Builder {
  public:
    Builder(const Mesh& mesh, const std::vector<Material>& materials,
            const TextureSampler* textures, const PointOctreeOptions& options, BuildBudget& budget,
            Progress* progress)
        : m_mesh(mesh),
          m_materials(materials),
          m_textures(textures),
          m_options(options),
          m_budget(budget),
          m_where("mesh '" + mesh.name + "'"),
          m_progress(progress) {}

    std::unique_ptr<OctreeBuildNode> build(std::vector<std::uint32_t> tris, int level) const {
        auto result = std::make_unique<OctreeBuildNode>();
        OctreeNode& node = result->node;
        node.level = level;
        std::tie(node.origin, node.side) = bounding_cube(m_mesh, tris);
        const int k = m_options.grid;
        const float voxel = node.side / static_cast<float>(k);
        const double voxel_d = static_cast<double>(node.side) / k;

        // Which triangles are large at this resolution (kept here) and which go down.
        std::vector<std::uint32_t> sample_counts(tris.size(), 0);
        std::vector<std::vector<std::uint32_t>> voxels(tris.size());
        std::vector<char> keep(tris.size(), 0);
        tbb::parallel_for(std::size_t{0}, tris.size(), [&](std::size_t i) {
            const std::uint32_t t = tris[i];
            // Enough samples for the area, and for a sliver's length: one per half voxel.
            const double density =
                std::max(kRepresentativeDensity * triangle_area(m_mesh, t) / (voxel_d * voxel_d),
                         2.0 * longest_edge(m_mesh, t) / voxel_d);
            const auto count = static_cast<std::uint32_t>(
                std::clamp(std::ceil(density), 1.0, static_cast<double>(1u << 30)));
            sample_counts[i] = count;
            if (level >= m_options.max_depth) {
                keep[i] = 1;
                return;
            }
            voxels[i] = representative_voxels(node, t, level, count);
            keep[i] = voxels[i].size() > static_cast<std::size_t>(m_options.max_representatives);
        });
        std::vector<std::uint32_t> passed;
        std::vector<std::uint32_t> passed_counts;
        std::vector<std::uint32_t> chosen;  // voxels of the passed triangles: the node's points
        for (std::size_t i = 0; i < tris.size(); ++i) {
            if (keep[i]) {
                node.triangles.push_back(tris[i]);
            } else {
                passed.push_back(tris[i]);
                passed_counts.push_back(sample_counts[i]);
                chosen.insert(chosen.end(), voxels[i].begin(), voxels[i].end());
            }
        }

        // Children by centroid. A split that makes no progress (everything in one child as
        // large as this node) would recurse forever: those triangles stay here.
        std::array<std::vector<std::uint32_t>, 8> octants;
        const Vec3f centre = node.origin + Vec3f::Constant(0.5f * node.side);
        for (const std::uint32_t t : passed) {
            const auto& tri = m_mesh.triangles[t];
            const Vec3f c =
                (m_mesh.positions[tri[0]] + m_mesh.positions[tri[1]] + m_mesh.positions[tri[2]]) /
                3.0f;
            const int octant = (c.x() >= centre.x() ? 1 : 0) | (c.y() >= centre.y() ? 2 : 0) |
                               (c.z() >= centre.z() ? 4 : 0);
            octants[static_cast<std::size_t>(octant)].push_back(t);
        }
        for (auto& octant : octants) {
            if (!octant.empty() && octant.size() == passed.size() &&
                bounding_cube(m_mesh, octant).second >= 0.999f * node.side) {
                node.triangles.insert(node.triangles.end(), octant.begin(), octant.end());
                std::sort(node.triangles.begin(), node.triangles.end());
                passed.clear();
                passed_counts.clear();
                chosen.clear();
                octant.clear();
            }
        }

        make_points(node, passed, passed_counts, std::move(chosen), level);
        if (m_progress != nullptr) {
            m_progress->advance(node.triangles.size());
        }
        if (std::any_of(octants.begin(), octants.end(),
                        [](const auto& octant) { return !octant.empty(); })) {
            m_budget.check_level(level + 1, m_where);
        }

        tbb::parallel_for(0, 8, [&](int c) {
            auto& octant = octants[static_cast<std::size_t>(c)];
            if (!octant.empty()) {
                result->children[static_cast<std::size_t>(c)] = build(std::move(octant), level + 1);
            }
        });

        // Bounds of the subtree: kept triangles, the points' voxels and the children.
        for (const std::uint32_t t : node.triangles) {
            for (const std::uint32_t v : m_mesh.triangles[t]) {
                node.bounds.extend(m_mesh.positions[v]);
            }
        }
        const Vec3f half_voxel = Vec3f::Constant(0.5f * voxel);
        for (const OctreePoint& p : node.points) {
            const Vec3f c = node.voxel_centre(p.voxel, k);
            node.bounds.extend(c - half_voxel);
            node.bounds.extend(c + half_voxel);
        }
        for (const auto& child : result->children) {
            if (child) {
                node.bounds.extend(child->node.bounds);
            }
        }
        set_bounding_sphere(node);
        return result;
    }

  private:
    Vec3f sample_position(std::uint32_t t, const Vec2f& b) const {
        const auto& tri = m_mesh.triangles[t];
        return (1.0f - b.x() - b.y()) * m_mesh.positions[tri[0]] +
               b.x() * m_mesh.positions[tri[1]] + b.y() * m_mesh.positions[tri[2]];
    }

    /// Distinct voxels hit by the first `count` samples of triangle t: its representatives.
    /// The search stops once there are more than the limit (the triangle is kept then,
    /// whatever the exact number).
    std::vector<std::uint32_t> representative_voxels(const OctreeNode& node, std::uint32_t t,
                                                     int level, std::uint32_t count) const {
        const std::uint64_t key = triangle_sample_key(m_options.seed, t, level);
        const auto limit = static_cast<std::size_t>(m_options.max_representatives);
        std::vector<std::uint32_t> voxels;
        for (std::uint32_t i = 0; i < count; ++i) {
            const Vec2f b = triangle_sample(i, key, TriangleSampling::LowDiscrepancy);
            const std::uint32_t v = voxel_index(node, m_options.grid, sample_position(t, b));
            if (std::find(voxels.begin(), voxels.end(), v) == voxels.end()) {
                voxels.push_back(v);
                if (voxels.size() > limit) {
                    break;
                }
            }
        }
        return voxels;
    }

    /// Points at the `chosen` voxels (the representatives of `tris`, with repeats), averaged
    /// from dense samples of `tris`; counts[i] is the representative-choosing sample count.
    void make_points(OctreeNode& node, const std::vector<std::uint32_t>& tris,
                     const std::vector<std::uint32_t>& counts, std::vector<std::uint32_t> chosen,
                     int level) const {
        if (tris.empty()) {
            return;
        }
        // The paper's oversampling factor c multiplies a minimum density of one sample per
        // voxel face area; every triangle gets at least its representative-choosing samples.
        const double voxel = static_cast<double>(node.side) / m_options.grid;
        const auto oversampling = static_cast<double>(std::max(1, m_options.oversampling));
        std::vector<std::size_t> offsets(tris.size() + 1, 0);
        for (std::size_t i = 0; i < tris.size(); ++i) {
            // A passed triangle meets at most max_representatives voxels, so this is a few
            // hundred samples at most.
            const double dense =
                std::ceil(oversampling * triangle_area(m_mesh, tris[i]) / (voxel * voxel));
            offsets[i + 1] = offsets[i] + std::max(static_cast<std::size_t>(counts[i]),
                                                   static_cast<std::size_t>(std::min(dense, 1e9)));
        }
        {
            std::vector<std::uint32_t> distinct = chosen;
            std::sort(distinct.begin(), distinct.end());
            m_budget.add_points(
                static_cast<std::uint64_t>(std::unique(distinct.begin(), distinct.end()) -
                                           distinct.begin()),
                m_where);
        }
        std::vector<SurfaceSample> samples(offsets.back());
        tbb::parallel_for(std::size_t{0}, tris.size(), [&](std::size_t i) {
            const std::span<SurfaceSample> out(samples.data() + offsets[i],
                                               offsets[i + 1] - offsets[i]);
            triangle_samples(m_mesh, m_materials, m_textures, tris[i],
                             triangle_sample_key(m_options.seed, tris[i], level), nullptr,
                             voxel * voxel, out, m_options.sampling);
            for (SurfaceSample& s : out) {
                s.voxel = voxel_index(node, m_options.grid, s.position);
            }
        });
        node.points = prefilter_points(node, m_options.grid, samples, std::move(chosen));
    }

    const Mesh& m_mesh;
    const std::vector<Material>& m_materials;
    const TextureSampler* m_textures;
    PointOctreeOptions m_options;
    BuildBudget& m_budget;
    std::string m_where;  ///< The mesh, for refusals.
    Progress* m_progress;
};

}  // namespace

PointOctree build_point_octree(const Mesh& mesh, const std::vector<Material>& materials,
                               const TextureSampler* textures, const PointOctreeOptions& options,
                               Progress* progress) {
    BuildBudget budget(options.budgets, mesh.name);
    return build_point_octree(mesh, materials, textures, options, budget, progress);
}

PointOctree build_point_octree(const Mesh& mesh, const std::vector<Material>& materials,
                               const TextureSampler* textures, const PointOctreeOptions& options,
                               BuildBudget& budget, Progress* progress) {
    if (options.grid < 1 || options.grid > 256) {
        throw Error("point octree: grid must be in [1, 256] (8-bit voxel indices), found " +
                    std::to_string(options.grid));
    }
    if (options.max_representatives < 1) {
        throw Error("point octree: max representatives must be at least 1");
    }
    PointOctree octree;
    octree.options = options;
    if (mesh.triangles.empty()) {
        return octree;
    }
    std::vector<std::uint32_t> all(mesh.triangles.size());
    std::iota(all.begin(), all.end(), 0u);
    // Every node's cube lies within the root's: checking the root's is enough.
    const Eigen::AlignedBox3d box = triangle_box(mesh, all);
    if (!cube_fits(box)) {
        throw Error(budget.file(), "mesh '" + mesh.name + "'", cube_overflow(box));
    }
    const Builder builder(mesh, materials, textures, options, budget, progress);
    std::unique_ptr<OctreeBuildNode> root = builder.build(std::move(all), 0);

    octree.nodes = breadth_first(std::move(root));
    return octree;
}

}  // namespace mrt
