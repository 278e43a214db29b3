#include "preprocess/point_octree.h"

#include "common/error.h"
#include "common/progress.h"
#include "common/texture.h"
#include "preprocess/normal_gradient.h"
#include "preprocess/triangle_sampling.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <memory>
#include <numeric>

namespace mrt {

namespace {

/// Samples per voxel face of area that choose the representatives. At 4 the R2 points on a
/// triangle are about half a voxel apart, so every point of the surface is within half a
/// voxel of a sample and within the voxel diagonal of that sample's voxel centre.
constexpr float kRepresentativeDensity = 4.0f;

/// Prefiltering neighbourhood: samples within this many voxels (σ) of a point's centre.
constexpr int kGatherRadius = 2;

struct Sample {
    Vec3f position;
    Vec3f normal;
    Rgb albedo;           ///< Diffuse colour times the texture at the sample's uv.
    std::uint32_t voxel;  ///< Linear voxel index in the node's grid.
    std::uint32_t material;
    float area;  ///< The surface area this sample stands for.
};

struct BuildNode {
    OctreeNode node;
    Eigen::AlignedBox3f bounds;  ///< Everything in the subtree.
    std::array<std::unique_ptr<BuildNode>, 8> children;
};

/// The smallest cube, centred on the triangles' bounds, that holds them with a small margin so
/// that no sample lands exactly on the far faces.
std::pair<Vec3f, float> bounding_cube(const Mesh& mesh, const std::vector<std::uint32_t>& tris) {
    Eigen::AlignedBox3f box;
    for (const std::uint32_t t : tris) {
        for (const std::uint32_t v : mesh.triangles[t]) {
            box.extend(mesh.positions[v]);
        }
    }
    const float side = std::max(box.sizes().maxCoeff(), 1e-30f) * (1.0f + 1e-4f) +
                       1e-6f * box.max().cwiseAbs().maxCoeff();
    return {box.center() - Vec3f::Constant(0.5f * side), side};
}

float triangle_area(const Mesh& mesh, std::uint32_t t) {
    const auto& tri = mesh.triangles[t];
    const Vec3f e1 = mesh.positions[tri[1]] - mesh.positions[tri[0]];
    const Vec3f e2 = mesh.positions[tri[2]] - mesh.positions[tri[0]];
    return 0.5f * e1.cross(e2).norm();
}

class Builder {
  public:
    Builder(const Mesh& mesh, const std::vector<Material>& materials,
            const TextureSampler* textures, const PointOctreeOptions& options, Progress* progress)
        : m_mesh(mesh),
          m_materials(materials),
          m_textures(textures),
          m_options(options),
          m_progress(progress) {}

    std::unique_ptr<BuildNode> build(std::vector<std::uint32_t> tris, int level) const {
        auto result = std::make_unique<BuildNode>();
        OctreeNode& node = result->node;
        node.level = level;
        std::tie(node.origin, node.side) = bounding_cube(m_mesh, tris);
        const int k = m_options.grid;
        const float voxel = node.side / static_cast<float>(k);

        // Which triangles are large at this resolution (kept here) and which go down.
        std::vector<std::uint32_t> sample_counts(tris.size(), 0);
        std::vector<std::vector<std::uint32_t>> voxels(tris.size());
        std::vector<char> keep(tris.size(), 0);
        tbb::parallel_for(std::size_t{0}, tris.size(), [&](std::size_t i) {
            const std::uint32_t t = tris[i];
            // Enough samples for the area, and for a sliver's length: one per half voxel.
            const auto& tri = m_mesh.triangles[t];
            const float longest =
                std::max({(m_mesh.positions[tri[1]] - m_mesh.positions[tri[0]]).norm(),
                          (m_mesh.positions[tri[2]] - m_mesh.positions[tri[1]]).norm(),
                          (m_mesh.positions[tri[0]] - m_mesh.positions[tri[2]]).norm()});
            const float density =
                std::max(kRepresentativeDensity * triangle_area(m_mesh, t) / (voxel * voxel),
                         2.0f * longest / voxel);
            const auto count = static_cast<std::uint32_t>(
                std::clamp(std::ceil(density), 1.0f, static_cast<float>(1u << 30)));
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

        tbb::parallel_for(0, 8, [&](int c) {
            auto& octant = octants[static_cast<std::size_t>(c)];
            if (!octant.empty()) {
                result->children[static_cast<std::size_t>(c)] = build(std::move(octant), level + 1);
            }
        });

        // Bounds of the subtree: kept triangles, the points' voxels and the children.
        for (const std::uint32_t t : node.triangles) {
            for (const std::uint32_t v : m_mesh.triangles[t]) {
                result->bounds.extend(m_mesh.positions[v]);
            }
        }
        const Vec3f half_voxel = Vec3f::Constant(0.5f * voxel);
        for (const OctreePoint& p : node.points) {
            const Vec3f c = node.voxel_centre(p.voxel, k);
            result->bounds.extend(c - half_voxel);
            result->bounds.extend(c + half_voxel);
        }
        for (const auto& child : result->children) {
            if (child) {
                result->bounds.extend(child->bounds);
            }
        }
        node.sphere_centre = result->bounds.center();
        node.sphere_radius = 0.5f * result->bounds.sizes().norm();
        return result;
    }

  private:
    std::uint32_t voxel_index(const OctreeNode& node, const Vec3f& p) const {
        const int k = m_options.grid;
        const Vec3f g = (p - node.origin) * (static_cast<float>(k) / node.side);
        std::uint32_t index = 0;
        for (int axis = 2; axis >= 0; --axis) {
            const int i = std::clamp(static_cast<int>(std::floor(g[axis])), 0, k - 1);
            index = index * static_cast<std::uint32_t>(k) + static_cast<std::uint32_t>(i);
        }
        return index;  // x fastest
    }

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
            const std::uint32_t v = voxel_index(node, sample_position(t, triangle_sample(i, key)));
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
        const float voxel = node.side / static_cast<float>(m_options.grid);
        const auto oversampling = static_cast<float>(std::max(1, m_options.oversampling));
        std::vector<std::size_t> offsets(tris.size() + 1, 0);
        for (std::size_t i = 0; i < tris.size(); ++i) {
            const float dense =
                std::ceil(oversampling * triangle_area(m_mesh, tris[i]) / (voxel * voxel));
            offsets[i + 1] = offsets[i] + std::max(static_cast<std::size_t>(counts[i]),
                                                   static_cast<std::size_t>(std::min(dense, 1e9f)));
        }
        std::vector<Sample> samples(offsets.back());
        tbb::parallel_for(std::size_t{0}, tris.size(), [&](std::size_t i) {
            const std::uint32_t t = tris[i];
            const auto& tri = m_mesh.triangles[t];
            const std::uint64_t key = triangle_sample_key(m_options.seed, t, level);
            const std::size_t n = offsets[i + 1] - offsets[i];
            const float area = triangle_area(m_mesh, t) / static_cast<float>(n);
            for (std::size_t j = 0; j < n; ++j) {
                const Vec2f b = triangle_sample(static_cast<std::uint32_t>(j), key);
                const float b0 = 1.0f - b.x() - b.y();
                Sample& s = samples[offsets[i] + j];
                s.position = sample_position(t, b);
                const Vec3f n3 = b0 * m_mesh.normals[tri[0]] + b.x() * m_mesh.normals[tri[1]] +
                                 b.y() * m_mesh.normals[tri[2]];
                s.normal = n3.squaredNorm() > 0.0f ? n3.normalized() : Vec3f::UnitZ();
                s.material = m_mesh.materials[t];
                const Material& material = m_materials[s.material];
                if (m_textures != nullptr && material.texture >= 0 && m_mesh.has_uvs()) {
                    const Vec2f uv = b0 * m_mesh.uvs[tri[0]] + b.x() * m_mesh.uvs[tri[1]] +
                                     b.y() * m_mesh.uvs[tri[2]];
                    s.albedo = m_textures->diffuse(material, uv);
                } else {
                    s.albedo = material.diffuse;
                }
                s.voxel = voxel_index(node, s.position);
                s.area = area;
            }
        });
        std::sort(chosen.begin(), chosen.end());
        chosen.erase(std::unique(chosen.begin(), chosen.end()), chosen.end());

        // Samples ordered by voxel, for the neighbourhood gathers.
        std::vector<std::uint32_t> order(samples.size());
        std::iota(order.begin(), order.end(), 0u);
        std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
            return samples[a].voxel < samples[b].voxel;
        });
        std::vector<std::uint32_t> sorted_voxels(order.size());
        for (std::size_t i = 0; i < order.size(); ++i) {
            sorted_voxels[i] = samples[order[i]].voxel;
        }

        std::vector<double> log_phong_of(m_materials.size());
        for (std::size_t m = 0; m < m_materials.size(); ++m) {
            log_phong_of[m] = std::log(std::max(m_materials[m].phong_exponent, 1e-3f));
        }
        node.points.resize(chosen.size());
        const int k = m_options.grid;
        const float sigma = voxel;
        const float inverse_two_sigma_squared = 0.5f / (sigma * sigma);
        const float cut = (static_cast<float>(kGatherRadius) + 0.5f) * sigma;
        // A plane through the point's centre gives its samples this weight: the Gaussian's
        // integral over the disc of radius `cut` it gathers from.
        const float gathered = 1.0f - std::exp(-0.5f * (cut / sigma) * (cut / sigma));
        const float plane_weight = 2.0f * kPi * sigma * sigma * gathered;
        tbb::parallel_for(std::size_t{0}, chosen.size(), [&](std::size_t r) {
            const std::uint32_t v = chosen[r];
            const int vx = static_cast<int>(v % static_cast<std::uint32_t>(k));
            const int vy = static_cast<int>((v / static_cast<std::uint32_t>(k)) %
                                            static_cast<std::uint32_t>(k));
            const int vz = static_cast<int>(v / static_cast<std::uint32_t>(k * k));
            OctreePoint& point = node.points[r];
            point.voxel = {static_cast<std::uint8_t>(vx), static_cast<std::uint8_t>(vy),
                           static_cast<std::uint8_t>(vz)};
            const Vec3f centre = node.voxel_centre(point.voxel, k);
            double weight_sum = 0.0;
            Eigen::Vector3d diffuse = Eigen::Vector3d::Zero(), specular = Eigen::Vector3d::Zero();
            double log_phong = 0.0, reflectivity = 0.0, transparency = 0.0, roughness = 0.0,
                   ior = 0.0;
            std::vector<NormalSample> neighbours;
            for (int dz = -kGatherRadius; dz <= kGatherRadius; ++dz) {
                for (int dy = -kGatherRadius; dy <= kGatherRadius; ++dy) {
                    for (int dx = -kGatherRadius; dx <= kGatherRadius; ++dx) {
                        const int x = vx + dx, y = vy + dy, z = vz + dz;
                        if (x < 0 || y < 0 || z < 0 || x >= k || y >= k || z >= k) {
                            continue;
                        }
                        const auto id = static_cast<std::uint32_t>((z * k + y) * k + x);
                        const auto range =
                            std::equal_range(sorted_voxels.begin(), sorted_voxels.end(), id);
                        for (auto it = range.first; it != range.second; ++it) {
                            const Sample& s = samples[order[static_cast<std::size_t>(
                                it - sorted_voxels.begin())]];
                            const float d2 = (s.position - centre).squaredNorm();
                            if (d2 > cut * cut) {
                                continue;
                            }
                            const double w = std::exp(-d2 * inverse_two_sigma_squared) * s.area;
                            const Material& m = m_materials[s.material];
                            weight_sum += w;
                            neighbours.push_back({s.position, s.normal, static_cast<float>(w)});
                            diffuse += w * s.albedo.matrix().cast<double>();
                            specular += w * m.specular.matrix().cast<double>();
                            log_phong += w * log_phong_of[s.material];
                            reflectivity += w * m.reflectivity;
                            transparency += w * m.transparency;
                            roughness += w * m.roughness;
                            ior += w * m.ior;
                        }
                    }
                }
            }
            if (!(weight_sum > 0.0)) {
                return;  // cannot happen: the point's own voxel holds samples
            }
            const double inv = 1.0 / weight_sum;
            const NormalGradientFit fit = fit_normal_gradient(centre, neighbours);
            point.normal = fit.normal;
            point.gradient = fit.gradient;
            point.gradient_fitted = fit.fitted;
            point.diffuse = (diffuse * inv).cast<float>().array();
            point.specular = (specular * inv).cast<float>().array();
            point.phong_exponent = static_cast<float>(std::exp(log_phong * inv));
            point.reflectivity = static_cast<float>(reflectivity * inv);
            point.transparency = static_cast<float>(transparency * inv);
            point.roughness = static_cast<float>(roughness * inv);
            point.ior = static_cast<float>(ior * inv);
            point.coverage = static_cast<float>(weight_sum / plane_weight);
        });
    }

    const Mesh& m_mesh;
    const std::vector<Material>& m_materials;
    const TextureSampler* m_textures;
    PointOctreeOptions m_options;
    Progress* m_progress;
};

}  // namespace

PointOctree build_point_octree(const Mesh& mesh, const std::vector<Material>& materials,
                               const TextureSampler* textures, const PointOctreeOptions& options,
                               Progress* progress) {
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
    const Builder builder(mesh, materials, textures, options, progress);
    std::unique_ptr<BuildNode> root = builder.build(std::move(all), 0);

    // Breadth-first, children in octant order: a layout fixed by the tree, not the schedule.
    std::deque<std::pair<BuildNode*, std::int32_t>> queue;  // node, parent slot to patch
    queue.emplace_back(root.get(), -1);
    while (!queue.empty()) {
        auto [build_node, parent_and_octant] = queue.front();
        queue.pop_front();
        const auto index = static_cast<std::int32_t>(octree.nodes.size());
        if (parent_and_octant >= 0) {
            octree.nodes[static_cast<std::size_t>(parent_and_octant / 8)]
                .children[static_cast<std::size_t>(parent_and_octant % 8)] = index;
        }
        octree.nodes.push_back(std::move(build_node->node));
        octree.nodes.back().children.fill(-1);
        for (int c = 0; c < 8; ++c) {
            if (build_node->children[static_cast<std::size_t>(c)]) {
                queue.emplace_back(build_node->children[static_cast<std::size_t>(c)].get(),
                                   index * 8 + c);
            }
        }
    }
    return octree;
}

}  // namespace mrt
