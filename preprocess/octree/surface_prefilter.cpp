#include "preprocess/octree/surface_prefilter.h"

#include "common/math/invertibility.h"
#include "common/texture/texture.h"
#include "preprocess/octree/normal_gradient.h"
#include "preprocess/octree/triangle_sampling.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace mrt {

namespace {

/// Prefiltering neighbourhood: samples within this many voxels (σ) of a point's centre.
constexpr int kGatherRadius = 2;

/// The voxel of linear index v (x fastest) in a k³ grid.
std::array<std::uint8_t, 3> voxel_coordinates(std::uint32_t v, int k) {
    const auto kk = static_cast<std::uint32_t>(k);
    return {static_cast<std::uint8_t>(v % kk), static_cast<std::uint8_t>((v / kk) % kk),
            static_cast<std::uint8_t>(v / (kk * kk))};
}

/// Calls f(linear index) for every voxel of the k³ grid within kGatherRadius voxels of voxel
/// v along each axis.
template <class F>
void for_each_voxel_near(std::uint32_t v, int k, const F& f) {
    const std::array<std::uint8_t, 3> c = voxel_coordinates(v, k);
    const int vx = c[0], vy = c[1], vz = c[2];
    for (int dz = -kGatherRadius; dz <= kGatherRadius; ++dz) {
        for (int dy = -kGatherRadius; dy <= kGatherRadius; ++dy) {
            for (int dx = -kGatherRadius; dx <= kGatherRadius; ++dx) {
                const int x = vx + dx, y = vy + dy, z = vz + dz;
                if (x >= 0 && y >= 0 && z >= 0 && x < k && y < k && z < k) {
                    f(static_cast<std::uint32_t>((z * k + y) * k + x));
                }
            }
        }
    }
}

}  // namespace

std::uint32_t voxel_index(const OctreeNode& node, int grid, const Vec3f& p) {
    const Vec3f g = (p - node.origin) * (static_cast<float>(grid) / node.side);
    std::uint32_t index = 0;
    for (int axis = 2; axis >= 0; --axis) {
        const int i = std::clamp(static_cast<int>(std::floor(g[axis])), 0, grid - 1);
        index = index * static_cast<std::uint32_t>(grid) + static_cast<std::uint32_t>(i);
    }
    return index;  // x fastest
}

double triangle_area(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
    const Vec3d e1 = (b - a).cast<double>();
    const Vec3d e2 = (c - a).cast<double>();
    return 0.5 * e1.cross(e2).norm();
}

double longest_edge(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
    const Vec3d pa = a.cast<double>(), pb = b.cast<double>(), pc = c.cast<double>();
    return std::max({(pb - pa).norm(), (pc - pb).norm(), (pa - pc).norm()});
}

void triangle_samples(const Mesh& mesh, const std::vector<Material>& materials,
                      const TextureSampler* textures, std::uint32_t t, std::uint64_t key,
                      const Affine3f* to_node, double voxel_face, std::span<SurfaceSample> out,
                      TriangleSampling scheme) {
    const auto& tri = mesh.triangles[t];
    std::array<Vec3f, 3> p{mesh.positions[tri[0]], mesh.positions[tri[1]], mesh.positions[tri[2]]};
    std::array<Vec3f, 3> n{mesh.normals[tri[0]], mesh.normals[tri[1]], mesh.normals[tri[2]]};
    if (to_node != nullptr) {
        const Mat3f normal_matrix = inverse_in_double(Mat3f(to_node->linear())).transpose();
        for (int i = 0; i < 3; ++i) {
            p[i] = *to_node * p[i];
            n[i] = normal_matrix * n[i];
        }
    }
    const auto share =
        static_cast<float>(triangle_area(p[0], p[1], p[2]) / voxel_face /
                           static_cast<double>(std::max<std::size_t>(out.size(), 1)));
    const Material& material = materials[mesh.materials[t]];
    const bool textured = textures != nullptr && material.texture >= 0 && mesh.has_uvs();
    // A cut-out's samples keep their area and carry its opacity (SurfaceSample::opacity).
    const bool cut = textures != nullptr && material.cut_out() && mesh.has_uvs();
    const double log_phong = std::log(std::max(material.phong_exponent, 1e-3f));
    for (std::size_t j = 0; j < out.size(); ++j) {
        const Vec2f b = triangle_sample(static_cast<std::uint32_t>(j), key, scheme);
        const float b0 = 1.0f - b.x() - b.y();
        SurfaceSample& s = out[j];
        s.position = b0 * p[0] + b.x() * p[1] + b.y() * p[2];
        const Vec3f n3 = b0 * n[0] + b.x() * n[1] + b.y() * n[2];
        s.normal = n3.squaredNorm() > 0.0f ? n3.normalized() : Vec3f::UnitZ();
        const Vec2f uv =
            textured || cut
                ? Vec2f(b0 * mesh.uvs[tri[0]] + b.x() * mesh.uvs[tri[1]] + b.y() * mesh.uvs[tri[2]])
                : Vec2f::Zero();
        s.diffuse = textured ? textures->diffuse(material, uv) : material.diffuse;
        s.specular = material.specular;
        s.log_phong = log_phong;
        s.reflectivity = material.reflectivity;
        s.transparency = material.transparency;
        s.roughness = material.roughness;
        s.ior = material.ior;
        s.emission = material.emission;
        s.opacity = cut ? std::clamp(textures->opacity(material, uv), 0.0f, 1.0f) : 1.0f;
        s.area = share;
    }
}

std::vector<OctreePoint> prefilter_points(const OctreeNode& node, int grid,
                                          const std::vector<SurfaceSample>& samples,
                                          std::vector<std::uint32_t> chosen) {
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

    std::vector<OctreePoint> points(chosen.size());
    const int k = grid;
    // Distances in voxel sides (σ): a squared distance in scene units overflows single
    // precision for nodes wider than about 1e19.
    const float sigma = node.side / static_cast<float>(grid);
    const float inverse_sigma = 1.0f / sigma;
    constexpr float kCut = static_cast<float>(kGatherRadius) + 0.5f;
    const auto in_sigmas = [&](const Vec3f& p, const Vec3f& centre) {
        return ((p - centre) * inverse_sigma).squaredNorm();
    };

    // Coverage is each point's share of the samples' area: a sample's area is split among
    // the points whose Gaussians reach it, in proportion to their weights, so the points'
    // coverages add up to the surface's area wherever it lies relative to the grid (slanted
    // surfaces occupy more voxels, each with less area) — what a ray's quadrature over the
    // points needs (common/footprint/point_weight.h). First each sample's total weight over the
    // points, one voxel of samples at a time (each sample written once: the same for any schedule).
    std::vector<double> total_weight(samples.size(), 0.0);
    std::vector<std::size_t> runs;  // starts of runs of one voxel in the sorted samples
    for (std::size_t i = 0; i < sorted_voxels.size(); ++i) {
        if (i == 0 || sorted_voxels[i] != sorted_voxels[i - 1]) {
            runs.push_back(i);
        }
    }
    runs.push_back(sorted_voxels.size());
    tbb::parallel_for(std::size_t{0}, runs.size() - 1, [&](std::size_t run) {
        std::vector<Vec3f> near;
        for_each_voxel_near(sorted_voxels[runs[run]], k, [&](std::uint32_t id) {
            if (std::binary_search(chosen.begin(), chosen.end(), id)) {
                near.push_back(node.voxel_centre(voxel_coordinates(id, k), k));
            }
        });
        for (std::size_t i = runs[run]; i < runs[run + 1]; ++i) {
            const SurfaceSample& s = samples[order[i]];
            double total = 0.0;
            for (const Vec3f& c : near) {
                const float d2 = in_sigmas(s.position, c);
                if (d2 <= kCut * kCut) {
                    total += std::exp(-0.5f * d2);
                }
            }
            total_weight[order[i]] = total;
        }
    });

    tbb::parallel_for(std::size_t{0}, chosen.size(), [&](std::size_t r) {
        const std::uint32_t v = chosen[r];
        OctreePoint& point = points[r];
        point.voxel = voxel_coordinates(v, k);
        const Vec3f centre = node.voxel_centre(point.voxel, k);
        double weight_sum = 0.0;
        double area_share = 0.0;
        Eigen::Vector3d diffuse = Eigen::Vector3d::Zero(), specular = Eigen::Vector3d::Zero();
        Eigen::Vector3d emission = Eigen::Vector3d::Zero();
        // Colour and emission of what stands: weighed by opacity too (a cut-out's holes are
        // often black in its colour texture), unless nothing under the Gaussian stands.
        Eigen::Vector3d standing_diffuse = Eigen::Vector3d::Zero();
        Eigen::Vector3d standing_emission = Eigen::Vector3d::Zero();
        double standing = 0.0;
        bool cut = false;
        Eigen::Vector3d normal_sum = Eigen::Vector3d::Zero();
        double log_phong = 0.0, reflectivity = 0.0, transparency = 0.0, roughness = 0.0, ior = 0.0;
        std::vector<NormalSample> neighbours;
        for_each_voxel_near(v, k, [&](std::uint32_t id) {
            const auto range = std::equal_range(sorted_voxels.begin(), sorted_voxels.end(), id);
            for (auto it = range.first; it != range.second; ++it) {
                const SurfaceSample& s =
                    samples[order[static_cast<std::size_t>(it - sorted_voxels.begin())]];
                const float d2 = in_sigmas(s.position, centre);
                if (d2 > kCut * kCut) {
                    continue;
                }
                const std::uint32_t index =
                    order[static_cast<std::size_t>(it - sorted_voxels.begin())];
                const double gauss = std::exp(-0.5f * d2);
                const double w = gauss * s.area;
                weight_sum += w;
                area_share += w / total_weight[index];
                neighbours.push_back({s.position, s.normal, static_cast<float>(w)});
                normal_sum += w * static_cast<double>(s.normal_length) * s.normal.cast<double>();
                diffuse += w * s.diffuse.matrix().cast<double>();
                specular += w * s.specular.matrix().cast<double>();
                log_phong += w * s.log_phong;
                reflectivity += w * s.reflectivity;
                transparency += w * s.transparency;
                roughness += w * s.roughness;
                ior += w * s.ior;
                emission += w * s.emission.matrix().cast<double>();
                cut = cut || s.opacity < 1.0f;
                const double ws = w * s.opacity;
                standing += ws;
                standing_diffuse += ws * s.diffuse.matrix().cast<double>();
                standing_emission += ws * s.emission.matrix().cast<double>();
            }
        });
        if (!(weight_sum > 0.0)) {
            return;  // only a voxel whose own samples all have zero area: coverage stays 0
        }
        const double inv = 1.0 / weight_sum;
        const NormalGradientFit fit = fit_normal_gradient(centre, neighbours);
        point.normal = fit.normal;
        double along = 0.0;
        for (const NormalSample& n : neighbours) {
            along += static_cast<double>(n.weight) * (n.position - centre).dot(fit.normal);
        }
        point.offset = static_cast<float>(along * inv / static_cast<double>(sigma));
        point.gradient = fit.gradient;
        point.gradient_fitted = fit.fitted;
        point.diffuse = (diffuse * inv).cast<float>().array();
        point.specular = (specular * inv).cast<float>().array();
        point.phong_exponent = static_cast<float>(std::exp(log_phong * inv));
        point.reflectivity = static_cast<float>(reflectivity * inv);
        point.transparency = static_cast<float>(transparency * inv);
        point.roughness = static_cast<float>(roughness * inv);
        point.ior = static_cast<float>(ior * inv);
        point.emission = (emission * inv).cast<float>().array();
        point.opacity = cut ? static_cast<float>(std::min(1.0, standing * inv)) : 1.0f;
        if (cut && standing > 0.0) {
            point.diffuse = (standing_diffuse / standing).cast<float>().array();
            point.emission = (standing_emission / standing).cast<float>().array();
        }
        point.coverage = static_cast<float>(area_share);  // the samples' areas are in voxel faces
        point.normal_length = static_cast<float>(std::min(1.0, normal_sum.norm() * inv));
    });
    return points;
}

}  // namespace mrt
