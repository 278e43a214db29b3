#include "common/mesh/procedural.h"

#include "common/math/random.h"

#include "common/system/budgets.h"
#include "common/system/error.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace mrt {

namespace {

// Vertex indices are 32-bit; keep well clear of the limit so index arithmetic cannot wrap.
constexpr long long kMaxVertices = 1LL << 30;

void require_positive_size(const char* recipe, const char* what, float value) {
    if (!std::isfinite(value) || !(value > 0.0f)) {
        throw Error(
            fmt::format("{}: {} must be a positive finite number (got {})", recipe, what, value));
    }
}

void require_vertex_budget(const char* recipe, long long vertices) {
    if (vertices > kMaxVertices) {
        throw Error(fmt::format("{}: the requested resolution needs {} vertices (at most {})",
                                recipe, vertices, kMaxVertices));
    }
}

std::uint32_t index(long long i) {
    return static_cast<std::uint32_t>(i);
}

}  // namespace

Mesh make_sphere(float radius, int segments, int rings, std::uint32_t material) {
    require_positive_size("sphere", "radius", radius);
    if (segments < 3) {
        throw Error(fmt::format("sphere: segments must be at least 3 (got {})", segments));
    }
    if (rings < 2) {
        throw Error(fmt::format("sphere: rings must be at least 2 (got {})", rings));
    }
    const long long seg = segments;
    const double seg_d = segments;
    const long long interior_rows = rings - 1;
    const long long vertex_count = 2 * seg + interior_rows * (seg + 1);
    require_vertex_budget("sphere", vertex_count);

    Mesh mesh;
    mesh.positions.reserve(static_cast<std::size_t>(vertex_count));
    mesh.normals.reserve(static_cast<std::size_t>(vertex_count));
    mesh.uvs.reserve(static_cast<std::size_t>(vertex_count));
    mesh.triangles.reserve(static_cast<std::size_t>(2 * seg * interior_rows));
    mesh.name = fmt::format("sphere(radius={}, segments={}, rings={})", radius, segments, rings);
    const auto add_vertex = [&mesh, radius](const Vec3d& unit, double u, double v) {
        const Vec3f n = unit.normalized().cast<float>();
        mesh.positions.push_back(radius * n);
        mesh.normals.push_back(n);
        mesh.uvs.emplace_back(static_cast<float>(u), static_cast<float>(v));
    };

    // Each pole gets one vertex per segment, with u at the segment's middle: a single shared
    // pole vertex would need one u for all directions, and a full row of coincident pole
    // vertices would make half of the cap's triangles degenerate.
    const long long north = 0;
    for (long long i = 0; i < seg; ++i) {
        add_vertex(Vec3d(0.0, 1.0, 0.0), (static_cast<double>(i) + 0.5) / seg_d, 1.0);
    }
    // Interior rows run from north to south; the last column repeats the first one's position
    // (computed from the same angle so it is bitwise identical) with u = 1, forming the seam.
    const long long first_row = seg;
    for (long long j = 1; j < rings; ++j) {
        const double theta = std::numbers::pi * static_cast<double>(j) / rings;
        for (long long i = 0; i <= seg; ++i) {
            const double phi = 2.0 * std::numbers::pi * static_cast<double>(i % seg) / seg_d;
            // Longitude grows eastwards seen from outside, so (dP/du, dP/dv, n) is right-handed
            // and textures are not mirrored.
            const Vec3d unit(-std::sin(theta) * std::cos(phi), std::cos(theta),
                             std::sin(theta) * std::sin(phi));
            add_vertex(unit, static_cast<double>(i) / seg_d, 1.0 - static_cast<double>(j) / rings);
        }
    }
    const long long south = first_row + interior_rows * (seg + 1);
    for (long long i = 0; i < seg; ++i) {
        add_vertex(Vec3d(0.0, -1.0, 0.0), (static_cast<double>(i) + 0.5) / seg_d, 0.0);
    }

    const auto row_vertex = [&](long long row, long long column) {
        return first_row + (row - 1) * (seg + 1) + column;
    };
    for (long long i = 0; i < seg; ++i) {
        mesh.triangles.push_back(
            {index(north + i), index(row_vertex(1, i)), index(row_vertex(1, i + 1))});
    }
    for (long long j = 1; j + 1 < rings; ++j) {
        for (long long i = 0; i < seg; ++i) {
            const std::uint32_t top_left = index(row_vertex(j, i));
            const std::uint32_t top_right = index(row_vertex(j, i + 1));
            const std::uint32_t bottom_left = index(row_vertex(j + 1, i));
            const std::uint32_t bottom_right = index(row_vertex(j + 1, i + 1));
            mesh.triangles.push_back({top_left, bottom_left, bottom_right});
            mesh.triangles.push_back({top_left, bottom_right, top_right});
        }
    }
    for (long long i = 0; i < seg; ++i) {
        mesh.triangles.push_back({index(row_vertex(rings - 1, i)), index(south + i),
                                  index(row_vertex(rings - 1, i + 1))});
    }
    mesh.materials.assign(mesh.triangles.size(), material);
    return mesh;
}

Mesh make_quad(float size_x, float size_z, std::uint32_t material) {
    require_positive_size("quad", "size_x", size_x);
    require_positive_size("quad", "size_z", size_z);
    Mesh mesh;
    mesh.name = fmt::format("quad({} x {})", size_x, size_z);
    const float hx = 0.5f * size_x;
    const float hz = 0.5f * size_z;
    // v grows towards −z so that (dP/du, dP/dv, +Y) is right-handed: seen from above the
    // texture reads unmirrored with −z as "up".
    mesh.positions = {Vec3f(-hx, 0.0f, -hz), Vec3f(-hx, 0.0f, hz), Vec3f(hx, 0.0f, hz),
                      Vec3f(hx, 0.0f, -hz)};
    mesh.uvs = {Vec2f(0.0f, 1.0f), Vec2f(0.0f, 0.0f), Vec2f(1.0f, 0.0f), Vec2f(1.0f, 1.0f)};
    mesh.normals.assign(4, Vec3f(0.0f, 1.0f, 0.0f));
    mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
    mesh.materials.assign(2, material);
    return mesh;
}

Mesh make_checkerboard(float size_x, float size_z, int tiles_x, int tiles_z,
                       std::uint32_t material_a, std::uint32_t material_b) {
    require_positive_size("checkerboard", "size_x", size_x);
    require_positive_size("checkerboard", "size_z", size_z);
    if (tiles_x < 1 || tiles_z < 1) {
        throw Error(fmt::format("checkerboard: tile counts must be at least 1 (got {} x {})",
                                tiles_x, tiles_z));
    }
    const long long nx = tiles_x;
    const long long nz = tiles_z;
    require_vertex_budget("checkerboard", (nx + 1) * (nz + 1));

    Mesh mesh;
    mesh.name =
        fmt::format("checkerboard({} x {}, {} x {} tiles)", size_x, size_z, tiles_x, tiles_z);
    // Coordinates come from the integer grid position so that shared corners are exact and the
    // outer edges land exactly on ±size/2.
    const auto coordinate = [](float size, long long i, long long n) {
        return static_cast<float>(static_cast<double>(size) *
                                  (static_cast<double>(i) / static_cast<double>(n) - 0.5));
    };
    for (long long iz = 0; iz <= nz; ++iz) {
        for (long long ix = 0; ix <= nx; ++ix) {
            mesh.positions.emplace_back(coordinate(size_x, ix, nx), 0.0f,
                                        coordinate(size_z, iz, nz));
            // Same orientation as make_quad: v grows towards −z.
            mesh.uvs.emplace_back(
                static_cast<float>(static_cast<double>(ix) / static_cast<double>(nx)),
                static_cast<float>(1.0 - static_cast<double>(iz) / static_cast<double>(nz)));
        }
    }
    mesh.normals.assign(mesh.positions.size(), Vec3f(0.0f, 1.0f, 0.0f));

    const auto vertex = [nx](long long ix, long long iz) { return index(iz * (nx + 1) + ix); };
    for (long long iz = 0; iz < nz; ++iz) {
        for (long long ix = 0; ix < nx; ++ix) {
            const std::uint32_t min_min = vertex(ix, iz);
            const std::uint32_t min_max = vertex(ix, iz + 1);
            const std::uint32_t max_max = vertex(ix + 1, iz + 1);
            const std::uint32_t max_min = vertex(ix + 1, iz);
            const std::uint32_t material = (ix + iz) % 2 == 0 ? material_a : material_b;
            mesh.triangles.push_back({min_min, min_max, max_max});
            mesh.triangles.push_back({min_min, max_max, max_min});
            mesh.materials.push_back(material);
            mesh.materials.push_back(material);
        }
    }
    return mesh;
}

namespace {

/// Appends a closed, tapering branch through `centres` with `radii` (one per centre): rings
/// of `sides` vertices (plus a seam vertex for the uvs) shared by consecutive segments, their
/// frames carried along by parallel transport so the rings do not twist, and a flat cap at
/// each end. Closed, so that a tracer can tell its back faces from its front (the branch is a
/// solid, thinner than a pixel from afar: two layers of coverage where there is one).
void add_branch(Mesh& mesh, const std::vector<Vec3f>& centres, const std::vector<float>& radii,
                int sides, std::uint32_t material) {
    const std::size_t rings = centres.size();
    const auto heading = [&](std::size_t r) {
        // At a joint the mean of the two segments' directions: the ring bisects the bend.
        const Vec3f in = r > 0 ? Vec3f(centres[r] - centres[r - 1]) : Vec3f::Zero();
        const Vec3f out = r + 1 < rings ? Vec3f(centres[r + 1] - centres[r]) : Vec3f::Zero();
        return Vec3f((in.normalized() + out.normalized()).normalized());
    };
    Vec3f up = heading(0);
    Vec3f side_a =
        (std::abs(up.x()) < 0.9f ? Vec3f::UnitX() : Vec3f::UnitZ()).cross(up).normalized();
    const auto first = static_cast<std::uint32_t>(mesh.positions.size());
    const auto row = static_cast<std::uint32_t>(sides + 1);
    for (std::size_t r = 0; r < rings; ++r) {
        if (r > 0) {
            up = heading(r);
            side_a = (side_a - side_a.dot(up) * up).normalized();
        }
        const Vec3f side_b = up.cross(side_a);
        for (int i = 0; i <= sides; ++i) {
            const float phi =
                2.0f * kPi * static_cast<float>(i % sides) / static_cast<float>(sides);
            const Vec3f radial = std::cos(phi) * side_a + std::sin(phi) * side_b;
            mesh.positions.push_back(centres[r] + radii[r] * radial);
            mesh.normals.push_back(radial);
            mesh.uvs.emplace_back(static_cast<float>(i) / static_cast<float>(sides),
                                  static_cast<float>(r) / static_cast<float>(rings - 1));
        }
    }
    const auto add = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
        mesh.triangles.push_back({a, b, c});
        mesh.materials.push_back(material);
    };
    for (std::uint32_t r = 0; r + 1 < rings; ++r) {
        for (std::uint32_t i = 0; i < static_cast<std::uint32_t>(sides); ++i) {
            const std::uint32_t a = first + r * row + i, b = a + 1, c = a + row, d = c + 1;
            add(a, b, d);
            add(a, d, c);
        }
    }
    // The side's winding faces out (b − a runs with φ, d − a along the branch: their cross
    // product is radial); each cap is wound the same way as seen from outside.
    for (const std::size_t r : {std::size_t{0}, rings - 1}) {
        const Vec3f normal = r == 0 ? Vec3f(-heading(0)) : heading(rings - 1);
        const auto centre = static_cast<std::uint32_t>(mesh.positions.size());
        mesh.positions.push_back(centres[r]);
        mesh.normals.push_back(normal);
        mesh.uvs.emplace_back(0.5f, r == 0 ? 0.0f : 1.0f);
        // The cap's rim: its own vertices (flat normal), at the ring's positions.
        const auto rim = static_cast<std::uint32_t>(mesh.positions.size());
        for (int i = 0; i < sides; ++i) {
            mesh.positions.push_back(
                mesh.positions[first + r * row + static_cast<std::uint32_t>(i)]);
            mesh.normals.push_back(normal);
            mesh.uvs.emplace_back(0.5f, r == 0 ? 0.0f : 1.0f);
        }
        for (std::uint32_t i = 0; i < static_cast<std::uint32_t>(sides); ++i) {
            const std::uint32_t a = rim + i;
            const std::uint32_t b = rim + (i + 1) % static_cast<std::uint32_t>(sides);
            const Vec3f winding = (mesh.positions[b] - mesh.positions[a])
                                      .cross(mesh.positions[centre] - mesh.positions[a]);
            if (winding.dot(normal) > 0.0f) {
                add(a, b, centre);
            } else {
                add(b, a, centre);
            }
        }
    }
}

/// Appends a leaf blade from `base` along `along`, `width` wide across `across`, bent along
/// `bend`: 5 rows of 2 vertices (tip shared), normals interpolated across the curve.
void add_leaf(Mesh& mesh, const Vec3f& base, const Vec3f& along, const Vec3f& across,
              const Vec3f& bend, float width, std::uint32_t material) {
    constexpr int kRows = 5;
    const auto first = static_cast<std::uint32_t>(mesh.positions.size());
    for (int r = 0; r < kRows; ++r) {
        const float t = static_cast<float>(r) / static_cast<float>(kRows - 1);
        const float half = 0.5f * width * std::sin(kPi * std::min(t, 0.999f)) + 1e-3f;
        const Vec3f centre = base + t * along + t * t * bend;
        const Vec3f tangent = (along + 2.0f * t * bend).normalized();
        const Vec3f normal = tangent.cross(across).normalized();
        for (int side = -1; side <= 1; side += 2) {
            mesh.positions.push_back(centre + static_cast<float>(side) * half * across);
            mesh.normals.push_back(normal);
            mesh.uvs.emplace_back(0.5f + 0.5f * static_cast<float>(side), t);
        }
    }
    for (std::uint32_t r = 0; r + 1 < kRows; ++r) {
        const std::uint32_t a = first + 2 * r, b = a + 1, c = a + 2, d = a + 3;
        mesh.triangles.push_back({a, b, d});
        mesh.triangles.push_back({a, d, c});
        mesh.materials.push_back(material);
        mesh.materials.push_back(material);
    }
}

void grow_branch(Mesh& mesh, std::uint64_t key, const Vec3f& base, const Vec3f& direction,
                 float length, float radius, int depth, int leaves, std::uint32_t stem,
                 std::uint32_t leaf) {
    SampleRng rng(key, 0, 0, 0);
    constexpr int kSegments = 4;
    Vec3f position = base;
    Vec3f heading = direction.normalized();
    std::vector<Vec3f> centres{base};
    std::vector<float> radii{radius};
    for (int s = 0; s < kSegments; ++s) {
        const Vec3f wobble(rng.uniform() - 0.5f, 0.3f * (rng.uniform() - 0.5f),
                           rng.uniform() - 0.5f);
        const Vec3f next_heading = (heading + 0.25f * wobble).normalized();
        const Vec3f axis = (length / kSegments) * next_heading;
        position += axis;
        heading = next_heading;
        centres.push_back(position);
        radii.push_back(radius * (1.0f - 0.6f * static_cast<float>(s + 1) / kSegments));
    }
    add_branch(mesh, centres, radii, 6, stem);
    const Vec3f side = (std::abs(heading.y()) < 0.9f ? Vec3f::UnitY() : Vec3f::UnitX())
                           .cross(heading)
                           .normalized();
    for (int l = 0; l < leaves; ++l) {
        const float t = (static_cast<float>(l) + 0.5f) / static_cast<float>(leaves);
        const float angle = 2.39996f * static_cast<float>(l) + rng.uniform();  // golden angle
        const Vec3f out = (std::cos(angle) * side + std::sin(angle) * heading.cross(side));
        const Vec3f leaf_base = base + t * (position - base);
        const Vec3f along = 0.18f * length * (out + 0.4f * heading).normalized();
        const Vec3f across = along.cross(heading).normalized();
        add_leaf(mesh, leaf_base, along, across, -0.05f * length * Vec3f::UnitY(), 0.06f * length,
                 leaf);
    }
    if (depth > 0) {
        for (int b = 0; b < 3; ++b) {
            const float angle = 2.0944f * static_cast<float>(b) + rng.uniform();
            const Vec3f out = std::cos(angle) * side + std::sin(angle) * heading.cross(side);
            grow_branch(mesh, mix64(key + static_cast<std::uint64_t>(b) + 1), position,
                        heading + 0.9f * out, 0.7f * length, 0.6f * radius, depth - 1, leaves, stem,
                        leaf);
        }
    }
}

}  // namespace

Mesh make_plant(std::uint64_t seed, int depth, int leaves_per_branch, std::uint32_t stem,
                std::uint32_t leaf) {
    if (depth < 0 || depth > kMaxPlantDepth) {
        throw Error(fmt::format("plant: depth must be in [0, {}] (got {})", kMaxPlantDepth, depth));
    }
    if (leaves_per_branch < 0 || leaves_per_branch > kMaxPlantLeavesPerBranch) {
        throw Error(fmt::format("plant: leaves per branch must be in [0, {}] (got {})",
                                kMaxPlantLeavesPerBranch, leaves_per_branch));
    }
    Mesh mesh;
    mesh.name = fmt::format("plant(seed={}, depth={}, leaves={})", seed, depth, leaves_per_branch);
    grow_branch(mesh, mix64(seed), Vec3f::Zero(), Vec3f::UnitY(), 0.45f, 0.02f, depth,
                leaves_per_branch, stem, leaf);
    return mesh;
}

}  // namespace mrt

namespace mrt {

std::uint64_t sphere_triangle_count(int segments, int rings) {
    // A fan at each pole and two triangles per cell of the rings − 2 bands between.
    const auto seg = static_cast<std::uint64_t>(std::max(segments, 3));
    const auto bands = static_cast<std::uint64_t>(std::max(rings, 2) - 1);
    return saturating_mul(2 * seg, bands);
}

std::uint64_t checkerboard_triangle_count(int tiles_x, int tiles_z) {
    return saturating_mul(2 * static_cast<std::uint64_t>(std::max(tiles_x, 1)),
                          static_cast<std::uint64_t>(std::max(tiles_z, 1)));
}

std::uint64_t plant_triangle_count(int depth, int leaves_per_branch) {
    // Every branch splits in three: 1 + 3 + … + 3^depth branches, each a stem of 4 segments of 6
    // sides (48 triangles) with two 6-triangle caps, and blades of 8 triangles.
    std::uint64_t branches = 0;
    std::uint64_t level = 1;
    for (int d = 0; d <= std::max(depth, 0); ++d) {
        branches = saturating_add(branches, level);
        level = saturating_mul(level, 3);
    }
    const auto leaves = static_cast<std::uint64_t>(std::max(leaves_per_branch, 0));
    return saturating_mul(branches, saturating_add(60, saturating_mul(8, leaves)));
}

}  // namespace mrt
