// Point weights (common/footprint/point_weight.h) against what they approximate: the integral of
// the normalised Gaussian over the surface a cone sees. On ideal lattices the sum must be κ (the
// analytic integral) and ripple no more than Poisson summation allows at the selection
// threshold; on real octrees (build_point_octree, coverage quantized as the file stores it)
// the sum over a surface's points must be at least one in the interior of the surface at every
// level, for footprints from the threshold to 4 h, anisotropy up to the clamp and incidence up
// to 80°, at most kPointWeightMaxInteriorSum, about half the interior's on a straight boundary
// and exactly zero away from the surface. Interior, boundary and outside are decided by
// geometry (the plane's edges, the sphere's silhouette, ray casts against the bunny's
// triangles), not by the points.

#include "common/footprint/point_weight.h"
#include "common/footprint/footprint.h"
#include "common/math/quantization.h"
#include "common/mesh/mesh_io.h"
#include "common/mesh/procedural.h"
#include "preprocess/octree/point_octree.h"
#include "tests/support/test_support.h"
#include "trace/bvh/triangle_bvh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <unordered_map>
#include <vector>

namespace mrt {
namespace {

/// The traversal's anisotropy clamp (Wand §5.1: 1/4–1/16; the brief of the cone tracer: 1/8).
constexpr float kMaxAnisotropy = 8.0f;

// ---------------------------------------------------------------------------------------------
// Ideal lattices: the analytic integral

/// Σ of the weights of the points (i·h, j·h) + offset of a plane whose normal is tilted by θ
/// from the ray about the v axis (so a plane step of h along u projects to h·cos θ), each of
/// coverage 1 — an ideal surface of one point per h².
double lattice_sum(const Mat2f& footprint, float h, float theta, const Vec2f& offset) {
    const PointWeightFrame frame = point_weight_frame(footprint, h);
    const float c = std::cos(theta);
    const Mat2f ellipse = frame.footprint * frame.footprint.transpose();
    const float reach =
        std::sqrt(kPointWeightClipExponent *
                  symmetric_eigen2(ellipse(0, 0), ellipse(0, 1), ellipse(1, 1)).major);
    const int nu = static_cast<int>(std::ceil(reach / (h * c))) + 2;
    const int nv = static_cast<int>(std::ceil(reach / h)) + 2;
    double sum = 0.0;
    for (int i = -nu; i <= nu; ++i) {
        for (int j = -nv; j <= nv; ++j) {
            const Vec2f plane = h * Vec2f(static_cast<float>(i), static_cast<float>(j)) + offset;
            sum += point_weight(frame, Vec2f(plane.x() * c, plane.y()), c, 1.0f);
        }
    }
    return sum;
}

TEST(PointWeight, IntegratesToKappaOverADenseSurfaceAtAnyIncidence) {
    // A footprint of 30 h × 10 h, rotated: the lattice sum is the integral of the normalised,
    // clip-compensated Gaussian, κ·1, up to the lattice's discretisation of the clip's edge
    // (weights of 2 % on a perimeter of ~300 points among ~4000/cos θ: below 0.3 %).
    const float h = 0.01f;
    const Mat2f f = Eigen::Rotation2Df(0.4f).toRotationMatrix() *
                    Eigen::Vector2f(15.0f * h, 5.0f * h).asDiagonal();
    for (const float degrees : {0.0f, 30.0f, 60.0f, 85.0f}) {
        const double sum = lattice_sum(f, h, degrees * kPi / 180.0f, Vec2f(0.37f * h, 0.71f * h));
        EXPECT_NEAR(sum / kPointWeightSafety, 1.0, 3e-3) << degrees << "°";
    }
}

TEST(PointWeight, RipplesLittleWithTheLatticeOffsetAtTheSelectionThreshold) {
    // Minimum diameter = h, isotropic: G·Gᵀ = (h/2)²·I + (β·h)²·I = h²/2·I, a Gaussian of
    // σ = h/2. Poisson summation over the lattice: Σ = (mean)·(1 + Σ_m e^{−π²|m|²/2}·cos(…)),
    // the four first harmonics e^{−π²/2} = 0.72 % each, so ±2.9 %, plus the clip's edge on so
    // few points (~8 inside): the sum must stay within ±5 % of κ at every offset.
    const float h = 1.0f;
    const Mat2f f = 0.5f * h * Mat2f::Identity();
    double lo = 1e30, hi = -1e30;
    for (int i = 0; i < 16; ++i) {
        for (int j = 0; j < 16; ++j) {
            const double sum =
                lattice_sum(f, h, 0.0f,
                            h * Vec2f(static_cast<float>(i), static_cast<float>(j)) / 16.0f) /
                kPointWeightSafety;
            lo = std::min(lo, sum);
            hi = std::max(hi, sum);
        }
    }
    EXPECT_GE(lo, 0.95);
    EXPECT_LE(hi, 1.05);
}

TEST(PointWeight, IsFiniteAndZeroWhereItMustBe) {
    const float h = 0.1f;
    const Mat2f f = 0.1f * Mat2f::Identity();
    const PointWeightFrame frame = point_weight_frame(f, h);
    EXPECT_EQ(point_weight(frame, Vec2f::Zero(), 0.0f, 1.0f), 0.0f);   // edge-on
    EXPECT_GT(point_weight(frame, Vec2f::Zero(), -1.0f, 1.0f), 0.0f);  // either side
    EXPECT_EQ(point_weight(frame, Vec2f::Zero(), -0.5f, 1.0f),
              point_weight(frame, Vec2f::Zero(), 0.5f, 1.0f));
    const float nan = std::numeric_limits<float>::quiet_NaN();
    EXPECT_EQ(point_weight(frame, Vec2f(nan, 0.0f), 1.0f, 1.0f), 0.0f);
    // Just outside the clip: nothing, and just inside: the clip's 2 % of the centre weight.
    const float edge = std::sqrt(kPointWeightClipExponent) * frame.footprint(0, 0);
    EXPECT_EQ(point_weight(frame, Vec2f(1.001f * edge, 0.0f), 1.0f, 1.0f), 0.0f);
    EXPECT_NEAR(point_weight(frame, Vec2f(0.9999f * edge, 0.0f), 1.0f, 1.0f) /
                    point_weight(frame, Vec2f::Zero(), 1.0f, 1.0f),
                kPointWeightClip, 1e-4);

    // A cone's apex (F = 0): the point's own kernel alone, G·Gᵀ = (β·h)²·I, so the centre
    // weight is κ·h²/(π·(β·h)²·(1 − clip)).
    const PointWeightFrame apex = point_weight_frame(Mat2f::Zero(), h);
    const float centre = kPointWeightSafety / (kPi * kPointKernelRadius * kPointKernelRadius *
                                               (1.0f - kPointWeightClip));
    EXPECT_NEAR(point_weight(apex, Vec2f::Zero(), 1.0f, 1.0f), centre, 1e-5f * centre);
    // Nothing to weigh with: zero spacing and zero footprint, or a non-finite footprint.
    EXPECT_EQ(point_weight_frame(Mat2f::Zero(), 0.0f).scale, 0.0f);
    EXPECT_EQ(point_weight(point_weight_frame(Mat2f::Zero(), 0.0f), Vec2f::Zero(), 1.0f, 1.0f),
              0.0f);
    EXPECT_EQ(point_weight_frame(Mat2f::Identity() * 1e30f, h).scale, 0.0f);
    EXPECT_EQ(point_weight_frame(Mat2f::Identity() * nan, h).scale, 0.0f);
    // A needle of a footprint, unclamped: still finite (the kernel bounds |det G| below).
    Mat2f needle;
    needle << 1e3f, 0.0f, 0.0f, 1e-20f;
    const PointWeightFrame thin = point_weight_frame(needle, h);
    EXPECT_TRUE(std::isfinite(thin.scale) && thin.scale > 0.0f) << thin;

    // The cone overload is F(t), clamped, then the frame.
    FootprintCone cone;
    cone.start_dev << 0.01f, 0.0f, 0.0f, 0.0f;
    cone.incr_dev << 0.2f, 0.05f, 0.0f, 0.001f;
    const PointWeightFrame at_t = point_weight_frame(cone, 2.0f, h, kMaxAnisotropy);
    const PointWeightFrame by_hand =
        point_weight_frame(FootprintCone::clamp_anisotropy(cone.at(2.0f), kMaxAnisotropy), h);
    EXPECT_EQ(at_t.scale, by_hand.scale);
    EXPECT_EQ(at_t.inverse, by_hand.inverse);
}

// ---------------------------------------------------------------------------------------------
// Real octrees

std::vector<Material> one_material() {
    Material m;
    m.diffuse = Rgb(0.5f, 0.5f, 0.5f);
    return {m};
}

Mesh transformed(Mesh mesh, const Mat3f& rotation, const Vec3f& offset) {
    for (Vec3f& p : mesh.positions) {
        p = rotation * p + offset;
    }
    for (Vec3f& n : mesh.normals) {
        n = rotation * n;
    }
    return mesh;
}

/// Indices of positions hashed into cubic cells, for box queries.
class PositionGrid {
  public:
    PositionGrid() = default;
    PositionGrid(const std::vector<Vec3f>& positions, float cell) : m_cell(cell) {
        for (std::size_t i = 0; i < positions.size(); ++i) {
            m_cells[key(cell_of(positions[i]))].push_back(static_cast<std::uint32_t>(i));
        }
    }

    template <typename F>
    void for_each_in_box(const Eigen::AlignedBox3f& box, const F& f) const {
        const Vec3i lo = cell_of(box.min());
        const Vec3i hi = cell_of(box.max());
        for (int z = lo.z(); z <= hi.z(); ++z) {
            for (int y = lo.y(); y <= hi.y(); ++y) {
                for (int x = lo.x(); x <= hi.x(); ++x) {
                    const auto it = m_cells.find(key(Vec3i(x, y, z)));
                    if (it == m_cells.end()) {
                        continue;
                    }
                    for (const std::uint32_t i : it->second) {
                        f(i);
                    }
                }
            }
        }
    }

  private:
    Vec3i cell_of(const Vec3f& p) const { return (p / m_cell).array().floor().cast<int>(); }
    static std::uint64_t key(const Vec3i& c) {
        const auto part = [](int v) {
            return static_cast<std::uint64_t>(v + (1 << 20)) & 0x1fffffu;
        };
        return (part(c.z()) << 42) | (part(c.y()) << 21) | part(c.x());
    }

    float m_cell = 1.0f;
    std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> m_cells;
};

/// The points of one octree level as the tracer will read them from the file.
struct LevelPoints {
    /// On the surface: voxel centre + decoded offset·h·normal (world space).
    std::vector<Vec3f> position;
    std::vector<Vec3f> normal;    ///< Decoded octahedral normals.
    std::vector<float> coverage;  ///< Decoded 8-bit coverage (decode_coverage8).
    std::vector<float> spacing;   ///< The node's voxel side h.
    float max_spacing = 0.0f;
    PositionGrid grid;
};

std::map<int, LevelPoints> points_by_level(const PointOctree& octree) {
    std::map<int, LevelPoints> levels;
    const int k = octree.options.grid;
    for (const OctreeNode& node : octree.nodes) {
        if (node.points.empty()) {
            continue;
        }
        LevelPoints& level = levels[node.level];
        const float h = node.side / static_cast<float>(k);
        for (const OctreePoint& p : node.points) {
            const Vec3f normal = decode_normal(encode_normal(p.normal));
            level.position.push_back(node.voxel_centre(p.voxel, k) +
                                     decode_offset8(encode_offset8(p.offset)) * h * normal);
            level.normal.push_back(normal);
            // As hierarchy_pack.cpp stores it.
            level.coverage.push_back(decode_coverage8(encode_coverage8(p.coverage)));
            level.spacing.push_back(h);
        }
    }
    for (auto& [l, level] : levels) {
        level.max_spacing = *std::max_element(level.spacing.begin(), level.spacing.end());
        level.grid = PositionGrid(level.position, 2.0f * level.max_spacing);
    }
    return levels;
}

/// The level of the node that keeps each triangle: level L's points stand for exactly the
/// triangles kept below L.
std::vector<int> kept_levels(const PointOctree& octree, std::size_t triangles) {
    std::vector<int> kept(triangles, -1);
    for (const OctreeNode& node : octree.nodes) {
        for (const std::uint32_t t : node.triangles) {
            kept[t] = node.level;
        }
    }
    return kept;
}

PositionGrid centroid_grid(const Mesh& mesh, float cell) {
    std::vector<Vec3f> centroids;
    for (const auto& tri : mesh.triangles) {
        centroids.push_back(
            (mesh.positions[tri[0]] + mesh.positions[tri[1]] + mesh.positions[tri[2]]) / 3.0f);
    }
    return PositionGrid(centroids, cell);
}

/// A cone whose axis hits a surface point: a thin perspective cone (apex 5000 h away, so F
/// changes by ≲ 3 % over the footprint even at grazing incidence, and one frame at the hit's
/// depth serves all points, as one per node will in the tracer) of random size from the
/// selection threshold to 4 h, anisotropy log-uniform up to the clamp, random orientation and
/// pixel-space rotation (F not symmetric), incidence uniform up to `max_incidence`.
struct TestCone {
    Vec3f hit;     ///< Where the axis meets the surface.
    Vec3f normal;  ///< The surface's normal there.
    Vec3f d;       ///< Unit direction.
    FootprintCone cone;
    float distance;      ///< From the apex (t = 0) to the hit.
    float min_diameter;  ///< Of F at the hit.
    float cos_theta;     ///< |d·normal|.
};

TestCone random_cone(std::mt19937_64& rng, const Vec3f& hit, const Vec3f& normal, float h,
                     float max_incidence_degrees) {
    std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
    TestCone c;
    c.hit = hit;
    c.normal = normal;
    const float theta = uniform(rng) * max_incidence_degrees * kPi / 180.0f;
    const float phi = uniform(rng) * 2.0f * kPi;
    Vec3f t, b;
    orthonormal_basis(normal, t, b);
    c.d = -(std::cos(theta) * normal + std::sin(theta) * (std::cos(phi) * t + std::sin(phi) * b))
               .normalized();
    c.cos_theta = std::abs(c.d.dot(normal));
    orthonormal_basis(c.d, c.cone.u, c.cone.v);
    c.min_diameter = h * (1.0f + 3.0f * uniform(rng));
    const float anisotropy = std::exp(uniform(rng) * std::log(kMaxAnisotropy));
    const Mat2f axes =
        Eigen::Rotation2Df(uniform(rng) * 2.0f * kPi).toRotationMatrix() *
        Vec2f(0.5f * c.min_diameter * anisotropy, 0.5f * c.min_diameter).asDiagonal();
    c.distance = 5000.0f * h;
    c.cone.incr_dev =
        axes * Eigen::Rotation2Df(uniform(rng) * 2.0f * kPi).toRotationMatrix() / c.distance;
    return c;
}

/// Offsets in the ray's u/v plane on the clip ellipse of the widest point footprint any node
/// the traversal may use here can give (spacing up to the minimum diameter), at 0, 1.02, 0.8
/// and ½ of it: where the cone reaches the surface.
std::vector<Vec2f> clip_outline(const TestCone& c) {
    const PointWeightFrame frame = point_weight_frame(c.cone.at(c.distance), c.min_diameter);
    std::vector<Vec2f> out{Vec2f::Zero()};
    for (const float r : {1.02f, 0.8f, 0.5f}) {  // outermost first: it fails first
        for (int a = 0; a < 32; ++a) {
            const float alpha = 2.0f * kPi * static_cast<float>(a) / 32.0f;
            out.push_back(r * std::sqrt(kPointWeightClipExponent) * frame.footprint *
                          Vec2f(std::cos(alpha), std::sin(alpha)));
        }
    }
    return out;
}

/// A box holding every point whose projection falls in the clip region: the surface points
/// the outline maps to, moved along the ray as far as a point 1.5 h off the surface projects,
/// and grown by 1.5 h.
Eigen::AlignedBox3f region_box(const std::vector<Vec3f>& surface, const TestCone& c, float h) {
    Eigen::AlignedBox3f core;
    for (const Vec3f& p : surface) {
        core.extend(p);
    }
    const Vec3f along = (1.5f * h / std::max(c.cos_theta, 0.1f)) * c.d;
    Eigen::AlignedBox3f box = core;
    for (const float s : {-1.0f, 1.0f}) {
        box.extend(core.min() + s * along);
        box.extend(core.max() + s * along);
    }
    box.min() -= Vec3f::Constant(1.5f * h);
    box.max() += Vec3f::Constant(1.5f * h);
    return box;
}

struct ConeSum {
    double sum = 0.0;          ///< Σ of the weights.
    float max_spacing = 0.0f;  ///< Largest h among the points that weigh something.
};

/// The weights a cone gives the points of `level` in `box` that `on_surface` accepts, with the
/// frame of each node spacing at the hit's depth, as the tracer makes one per node.
ConeSum weight_sum(const TestCone& c, const LevelPoints& level, const Eigen::AlignedBox3f& box,
                   const std::function<bool(std::uint32_t)>& on_surface) {
    ConeSum result;
    std::vector<std::pair<float, PointWeightFrame>> frames;
    level.grid.for_each_in_box(box, [&](std::uint32_t i) {
        if (!on_surface(i)) {
            return;
        }
        const float h = level.spacing[i];
        auto frame =
            std::find_if(frames.begin(), frames.end(), [h](const auto& f) { return f.first == h; });
        if (frame == frames.end()) {
            frames.emplace_back(h, point_weight_frame(c.cone, c.distance, h, kMaxAnisotropy));
            frame = frames.end() - 1;
        }
        const Vec3f x = level.position[i] - c.hit;
        const float w = point_weight(frame->second, Vec2f(x.dot(c.cone.u), x.dot(c.cone.v)),
                                     level.normal[i].dot(c.d), level.coverage[i]);
        result.sum += w;
        if (w > 0.0f) {
            result.max_spacing = std::max(result.max_spacing, level.spacing[i]);
        }
    });
    return result;
}

/// The voxel side of the level's point nearest to p (the node the traversal reaches there), or
/// 0 when the level has no point within a few voxels.
float spacing_near(const LevelPoints& level, const Vec3f& p) {
    const float radius = 4.0f * level.max_spacing;
    float best = kInfinity;
    float h = 0.0f;
    level.grid.for_each_in_box(
        Eigen::AlignedBox3f(p - Vec3f::Constant(radius), p + Vec3f::Constant(radius)),
        [&](std::uint32_t i) {
            const float d = (level.position[i] - p).squaredNorm();
            if (d < best) {
                best = d;
                h = level.spacing[i];
            }
        });
    return h;
}

struct Stats {
    double min = kInfinity, max = -kInfinity, sum = 0.0;
    int n = 0;
    void add(double x) {
        min = std::min(min, x);
        max = std::max(max, x);
        sum += x;
        ++n;
    }
    double mean() const { return n > 0 ? sum / n : 0.0; }
};

/// MRT_POINT_WEIGHT_CONES=n multiplies the cone counts by n (docs/point-weights.md: 8).
int scale() {
    const char* s = std::getenv("MRT_POINT_WEIGHT_CONES");
    return s != nullptr ? std::max(1, std::atoi(s)) : 1;
}

void print_row(const std::string& name, int level, const Stats& s) {
    if (s.n == 0) {
        return;
    }
    std::printf("  weight sum  %-26s level %d  cones %4d  min %.3f  mean %.3f  max %.3f\n",
                name.c_str(), level, s.n, s.min, s.mean(), s.max);
}

/// The interior bounds, checked on every cone (the sums print as a table for the docs).
void expect_interior(const std::string& name, int level, const Stats& s) {
    print_row(name + " interior", level, s);
    if (s.n == 0) {
        return;
    }
    EXPECT_GE(s.min, 1.0) << name << " level " << level;
    EXPECT_LE(s.max, kPointWeightMaxInteriorSum) << name << " level " << level;
}

/// A 4 × 4 checkerboard of 64² tiles (small triangles, so that levels 0–2 are all points),
/// rotated so that its normal is `normal`, at an offset that keeps it off the grid's symmetry.
/// Cones: interior (the clip region 3 diameters inside the edges), on the edge x = +2 (the
/// region reaching 3 diameters from the other edges), and beyond it (the region clear of the
/// edge by 3 diameters and the reach of points 1.5 h off the plane).
void check_plane(const std::string& name, const Vec3f& normal_direction) {
    const Vec3f n = normal_direction.normalized();
    const Mat3f rotation = Eigen::Quaternionf::FromTwoVectors(Vec3f::UnitY(), n).toRotationMatrix();
    const Vec3f offset(0.013f, 0.021f, -0.007f);
    const float size = 4.0f;
    const Mesh quad = transformed(make_checkerboard(size, size, 64, 64, 0, 0), rotation, offset);
    const PointOctree octree = build_point_octree(quad, one_material(), nullptr, {});
    const auto levels = points_by_level(octree);
    const std::vector<int> kept = kept_levels(octree, quad.triangles.size());
    const PositionGrid triangles = centroid_grid(quad, 0.1f);
    const Vec3f ex = rotation * Vec3f::UnitX();
    const Vec3f ez = rotation * Vec3f::UnitZ();
    const auto local = [&](const Vec3f& p) {
        return Vec2f((p - offset).dot(ex), (p - offset).dot(ez));
    };
    std::mt19937_64 rng(77);
    std::uniform_real_distribution<float> uniform(-0.5f, 0.5f);
    int interior_cones = 0;
    for (const auto& [l, level] : levels) {
        enum Kind { kInterior, kEdge, kOutside };
        Stats stats[3];
        for (const Kind kind : {kInterior, kEdge, kOutside}) {
            const int wanted = scale() * (kind == kInterior ? 150 : kind == kEdge ? 60 : 20);
            for (int attempt = 0; attempt < 40 * wanted && stats[kind].n < wanted; ++attempt) {
                Vec2f at(uniform(rng) * size, uniform(rng) * size);
                if (kind == kEdge) {
                    at.x() = 0.5f * size;
                } else if (kind == kOutside) {
                    at.x() = size * (1.0f + uniform(rng));
                }
                const Vec3f s = offset + at.x() * ex + at.y() * ez;
                const float h =
                    spacing_near(level, offset + std::min(at.x(), 0.5f * size) * ex + at.y() * ez);
                if (!(h > 0.0f)) {
                    continue;
                }
                const TestCone c = random_cone(rng, s, n, h, 80.0f);
                const float margin = 3.0f * c.min_diameter;
                const float inside = 0.5f * size - margin;
                std::vector<Vec3f> mapped;
                bool placed = true;
                for (const Vec2f& x : clip_outline(c)) {
                    const Vec3f q = s + x.x() * c.cone.u + x.y() * c.cone.v;
                    const Vec3f p = q - ((q - s).dot(n) / c.d.dot(n)) * c.d;  // along d
                    mapped.push_back(p);
                    const Vec2f lp = local(p);
                    placed =
                        placed && std::abs(lp.y()) < inside &&
                        (kind == kInterior ? std::abs(lp.x()) < inside
                         : kind == kEdge   ? lp.x() > -inside
                                         : lp.x() > 0.5f * size + margin + 1.5f * h / c.cos_theta);
                }
                if (!placed) {
                    continue;
                }
                const Eigen::AlignedBox3f box = region_box(mapped, c, c.min_diameter);
                bool represented = true;
                triangles.for_each_in_box(
                    box, [&](std::uint32_t t) { represented = represented && kept[t] > l; });
                if (!represented && kind != kOutside) {
                    continue;  // level l draws some of this surface as triangles
                }
                const ConeSum sum = weight_sum(c, level, box, [](std::uint32_t) { return true; });
                if (sum.max_spacing > c.min_diameter) {
                    continue;  // the traversal would go deeper there
                }
                if (kind == kOutside) {
                    EXPECT_EQ(sum.sum, 0.0) << name << " level " << l << " at " << at.transpose();
                }
                stats[kind].add(sum.sum);
            }
        }
        expect_interior(name, l, stats[kInterior]);
        interior_cones += stats[kInterior].n;
        print_row(name + " edge", l, stats[kEdge]);
        print_row(name + " outside", l, stats[kOutside]);
        if (stats[kEdge].n >= 50 && stats[kInterior].n >= 50) {
            // A symmetric kernel centred on a straight boundary sees half the surface. The
            // coverage ramp at a boundary is the gathered Gaussian (σ = h) of the samples inside
            // it, which puts the half-way point a fraction of a voxel inside (measured ratios
            // 0.38–0.52 on footprints of 1–4 h): the mean edge sum is 0.5 ± 0.15 of the
            // interior's.
            const double ratio = stats[kEdge].mean() / stats[kInterior].mean();
            EXPECT_NEAR(ratio, 0.5, 0.15) << name << " level " << l;
        }
    }
    EXPECT_GE(interior_cones, 200) << name;
}

TEST(PointWeight, PlanesSumToAtLeastOneInsideHalfOnTheEdgeAndZeroOutside) {
    check_plane("plane on the grid", Vec3f(0.0f, 1.0f, 0.0f));
    check_plane("plane tilted 1°", Vec3f(0.0f, 1.0f, 0.0175f));  // crosses voxel layers
    check_plane("plane at 45° to x and z", Vec3f(1.0f, 0.0f, 1.0f));
    check_plane("plane at 45° to every axis", Vec3f(1.0f, 1.0f, 1.0f));
    check_plane("plane at random", Vec3f(0.3f, 1.0f, 0.6f));
    check_plane("plane at random 2", Vec3f(-0.8f, 0.35f, 0.5f));
}

TEST(PointWeight, ASphereSumsToAtLeastOneInsideItsSilhouette) {
    // Radius 1, 192 × 96 facets: levels 0–2 are all points. A cone is in the interior when
    // every line of its clip outline meets the sphere 3 diameters inside the silhouette, and
    // it sums the front points (those before the centre along the ray; the back surface is
    // another fragment).
    const float radius = 1.0f;
    const Vec3f centre(0.013f, 0.021f, -0.007f);
    const Mesh sphere = transformed(make_sphere(radius, 192, 96, 0), Mat3f::Identity(), centre);
    const PointOctree octree = build_point_octree(sphere, one_material(), nullptr, {});
    const auto levels = points_by_level(octree);
    const std::vector<int> kept = kept_levels(octree, sphere.triangles.size());
    const PositionGrid triangles = centroid_grid(sphere, 0.05f);
    std::mt19937_64 rng(78);
    int interior_cones = 0;
    for (const auto& [l, level] : levels) {
        Stats stats;
        for (int attempt = 0; attempt < 40 * 150 * scale() && stats.n < 150 * scale(); ++attempt) {
            const Vec3f m = testing::random_direction(rng).cast<float>();
            const Vec3f s = centre + radius * m;
            const float h = spacing_near(level, s);
            if (!(h > 0.0f)) {
                continue;
            }
            const TestCone c = random_cone(rng, s, m, h, 80.0f);
            std::vector<Vec3f> mapped;
            bool inside = true;
            const float limit = radius - 3.0f * c.min_diameter;
            for (const Vec2f& x : clip_outline(c)) {
                const Vec3f q = s + x.x() * c.cone.u + x.y() * c.cone.v;
                const Vec3f w = q - centre;
                const float off_axis2 = (w - w.dot(c.d) * c.d).squaredNorm();
                if (!(off_axis2 < limit * limit)) {
                    inside = false;
                    break;
                }
                mapped.push_back(q - (w.dot(c.d) + std::sqrt(radius * radius - off_axis2)) * c.d);
            }
            if (!inside) {
                continue;
            }
            const Eigen::AlignedBox3f box = region_box(mapped, c, c.min_diameter);
            bool represented = true;
            triangles.for_each_in_box(
                box, [&](std::uint32_t t) { represented = represented && kept[t] > l; });
            if (!represented) {
                continue;
            }
            const ConeSum sum = weight_sum(c, level, box, [&](std::uint32_t i) {
                return (level.position[i] - centre).dot(c.d) < 0.0f;
            });
            if (sum.max_spacing > c.min_diameter) {
                continue;
            }
            stats.add(sum.sum);
        }
        expect_interior("sphere", l, stats);
        interior_cones += stats.n;
    }
    EXPECT_GE(interior_cones, 200);
}

TEST(PointWeight, TheBunnySumsToAtLeastOneWhereItIsOneSmoothSheet) {
    // The bunny is neither flat nor closed (holes underneath), so the interior is decided by
    // casting the clip outline's lines against its triangles: each must hit a triangle that
    // this level draws as points, within 0.3 h of the tangent plane at the cone's hit (one
    // sheet, not a fold or an occluder), with nothing behind it within 3 diameters (no second
    // sheet whose points would join the fragment). The fragment is the points within 0.9 h
    // (a voxel centre's reach) + 0.3 h of that plane, facing its side. Incidence up to 60°:
    // beyond it the bunny's curvature leaves hardly any footprint one flat sheet.
    const auto path = testing::find_data_file("meshes/stanford-bunny.obj");
    ASSERT_TRUE(path.has_value()) << "stanford-bunny.obj not on the data search path";
    const Mesh bunny = load_mesh(*path, 0).mesh;
    const PointOctree octree = build_point_octree(bunny, one_material(), nullptr, {});
    const auto levels = points_by_level(octree);
    const std::vector<int> kept = kept_levels(octree, bunny.triangles.size());
    const TriangleBvh bvh(bunny);
    std::vector<double> cdf;  // area-uniform choice of the hit's triangle
    double area = 0.0;
    for (const auto& tri : bunny.triangles) {
        area += 0.5 * (bunny.positions[tri[1]] - bunny.positions[tri[0]])
                          .cross(bunny.positions[tri[2]] - bunny.positions[tri[0]])
                          .norm();
        cdf.push_back(area);
    }
    std::mt19937_64 rng(79);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    int interior_cones = 0;
    for (const auto& [l, level] : levels) {
        Stats stats;
        // Levels whose voxels are large beside the bunny's curvature rarely see a flat sheet:
        // give up on one after 3000 fruitless attempts.
        for (int attempt = 0; attempt < 60 * 150 * scale() && stats.n < 150 * scale() &&
                              (attempt < 3000 || stats.n > 0);
             ++attempt) {
            const auto t = static_cast<std::size_t>(
                std::lower_bound(cdf.begin(), cdf.end(), uniform(rng) * area) - cdf.begin());
            if (t >= bunny.triangles.size() || kept[t] <= l) {
                continue;
            }
            const auto& tri = bunny.triangles[t];
            float b1 = static_cast<float>(uniform(rng));
            float b2 = static_cast<float>(uniform(rng));
            if (b1 + b2 > 1.0f) {
                b1 = 1.0f - b1;
                b2 = 1.0f - b2;
            }
            const float b0 = 1.0f - b1 - b2;
            const Vec3f s = b0 * bunny.positions[tri[0]] + b1 * bunny.positions[tri[1]] +
                            b2 * bunny.positions[tri[2]];
            const Vec3f m = (b0 * bunny.normals[tri[0]] + b1 * bunny.normals[tri[1]] +
                             b2 * bunny.normals[tri[2]])
                                .normalized();
            const float h = spacing_near(level, s);
            if (!(h > 0.0f)) {
                continue;
            }
            const TestCone c = random_cone(rng, s, m, h, 60.0f);
            const float flat = 0.3f * h;
            std::vector<Vec3f> mapped;
            bool sheet = true;
            for (const Vec2f& x : clip_outline(c)) {
                Ray ray;
                ray.origin =
                    s + x.x() * c.cone.u + x.y() * c.cone.v - 100.0f * c.min_diameter * c.d;
                ray.direction = c.d;
                TriangleHit hit;
                if (!bvh.intersect(ray, hit) || kept[hit.triangle] <= l) {
                    sheet = false;
                    break;
                }
                const Vec3f p = ray.origin + hit.t * c.d;
                Ray behind;
                behind.origin = p + 1e-4f * c.min_diameter * c.d;
                behind.direction = c.d;
                TriangleHit second;
                if (std::abs((p - s).dot(m)) > flat ||
                    (bvh.intersect(behind, second) &&
                     std::abs((behind.origin + second.t * c.d - s).dot(m)) <
                         3.0f * c.min_diameter)) {
                    sheet = false;
                    break;
                }
                mapped.push_back(p);
            }
            if (!sheet) {
                continue;
            }
            const Eigen::AlignedBox3f box = region_box(mapped, c, c.min_diameter);
            const ConeSum sum = weight_sum(c, level, box, [&](std::uint32_t i) {
                return std::abs((level.position[i] - s).dot(m)) <= 0.9f * level.spacing[i] + flat &&
                       level.normal[i].dot(m) > 0.0f;
            });
            if (sum.max_spacing > c.min_diameter) {
                continue;
            }
            stats.add(sum.sum);
        }
        expect_interior("bunny", l, stats);
        interior_cones += stats.n;
    }
    EXPECT_GE(interior_cones, 200);
}

}  // namespace
}  // namespace mrt
