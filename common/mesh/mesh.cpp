#include "common/mesh/mesh.h"

#include "common/math/position_weld.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <ostream>

namespace mrt {

namespace {

// A triangle is degenerate when |e1 × e2| is below this fraction of its squared longest edge:
// its apex is then closer to the opposite edge than float coordinates (~6e-8 relative
// precision) can place it, so its normal is rounding noise. Real slivers sit far above this;
// the flattest triangle of the shared test meshes is at 7e-3.
constexpr double kDegenerateRelativeArea = 1e-10;

Vec3d to_double(const Vec3f& v) {
    return v.cast<double>();
}

bool indices_valid(const std::array<std::uint32_t, 3>& t, std::size_t vertex_count) {
    return t[0] < vertex_count && t[1] < vertex_count && t[2] < vertex_count && t[0] != t[1] &&
           t[1] != t[2] && t[0] != t[2];
}

/// Twice the triangle's vector area, or nothing when the triangle has no usable area. Doubles
/// make the cross product of float inputs nearly exact, so the tolerance below decides alone.
std::optional<Vec3d> area_vector(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
    if (!all_finite(a) || !all_finite(b) || !all_finite(c)) {
        return std::nullopt;
    }
    const Vec3d pa = to_double(a);
    const Vec3d e0 = to_double(b) - pa;
    const Vec3d e1 = to_double(c) - pa;
    const Vec3d e2 = to_double(c) - to_double(b);
    const Vec3d cross = e0.cross(e1);
    const double cross_norm = cross.norm();
    const double longest_squared = std::max({e0.squaredNorm(), e1.squaredNorm(), e2.squaredNorm()});
    if (!(cross_norm > kDegenerateRelativeArea * longest_squared) || !std::isfinite(cross_norm)) {
        return std::nullopt;
    }
    return cross;
}

/// Angle between two vectors; atan2 stays accurate for angles near 0 and π where acos does not.
double angle_between(const Vec3d& u, const Vec3d& v) {
    return std::atan2(u.cross(v).norm(), u.dot(v));
}

}  // namespace

Eigen::AlignedBox3f Mesh::bounds() const {
    Eigen::AlignedBox3f box(Vec3f::Constant(kInfinity), Vec3f::Constant(-kInfinity));
    for (const Vec3f& p : positions) {
        box.extend(p);
    }
    return box;
}

void compute_vertex_normals(Mesh& mesh) {
    const std::size_t n = mesh.positions.size();
    std::vector<Vec3d> sum(n, Vec3d::Zero());
    // A vertex whose weighted normals cancel (two faces back to back) still has a sensible
    // answer: the normal of its widest incident corner.
    std::vector<Vec3d> widest_normal(n, Vec3d::Zero());
    std::vector<double> widest_angle(n, -1.0);

    for (const auto& t : mesh.triangles) {
        if (!indices_valid(t, n)) {
            continue;
        }
        const std::optional<Vec3d> area =
            area_vector(mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]);
        if (!area) {
            continue;
        }
        const Vec3d face_normal = area->normalized();
        for (int corner = 0; corner < 3; ++corner) {
            const std::uint32_t v = t[corner];
            const Vec3d p = to_double(mesh.positions[v]);
            const Vec3d to_next = to_double(mesh.positions[t[(corner + 1) % 3]]) - p;
            const Vec3d to_prev = to_double(mesh.positions[t[(corner + 2) % 3]]) - p;
            const double angle = angle_between(to_next, to_prev);
            sum[v] += angle * face_normal;
            if (angle > widest_angle[v]) {
                widest_angle[v] = angle;
                widest_normal[v] = face_normal;
            }
        }
    }

    mesh.normals.resize(n);
    for (std::size_t v = 0; v < n; ++v) {
        const double length = sum[v].norm();
        // The sum of unit normals weighted by angles up to 2π is either of order 1 or the result
        // of cancellation; a tiny length means its direction is rounding noise.
        if (length > 1e-9 && std::isfinite(length)) {
            mesh.normals[v] = (sum[v] / length).cast<float>();
        } else if (widest_angle[v] >= 0.0) {
            mesh.normals[v] = widest_normal[v].cast<float>();
        } else {
            mesh.normals[v] = Vec3f(0.0f, 0.0f, 1.0f);
        }
    }
}

void compute_creased_normals(Mesh& mesh, double crease_angle, const std::vector<bool>& given) {
    const std::size_t vertex_count = mesh.positions.size();
    std::vector<std::uint32_t> representative;
    const std::vector<std::uint32_t> welded = weld_positions(
        vertex_count, [&](std::size_t v) { return mesh.positions[v]; }, representative);
    const std::size_t triangle_count = mesh.triangles.size();

    // Each face's unit normal (zero for one without usable area) and each corner's angle.
    std::vector<Vec3d> face_normal(triangle_count, Vec3d::Zero());
    std::vector<std::array<double, 3>> corner_angle(triangle_count, {0.0, 0.0, 0.0});
    for (std::size_t t = 0; t < triangle_count; ++t) {
        const auto& tri = mesh.triangles[t];
        if (!indices_valid(tri, vertex_count)) {
            continue;
        }
        const std::optional<Vec3d> area =
            area_vector(mesh.positions[tri[0]], mesh.positions[tri[1]], mesh.positions[tri[2]]);
        if (!area) {
            continue;
        }
        face_normal[t] = area->normalized();
        for (std::size_t corner = 0; corner < 3; ++corner) {
            const Vec3d p = to_double(mesh.positions[tri[corner]]);
            corner_angle[t][corner] =
                angle_between(to_double(mesh.positions[tri[(corner + 1) % 3]]) - p,
                              to_double(mesh.positions[tri[(corner + 2) % 3]]) - p);
        }
    }

    // The corners at each welded position, in triangle order (compressed rows).
    std::vector<std::size_t> first(representative.size() + 1, 0);
    for (const auto& tri : mesh.triangles) {
        for (const std::uint32_t v : tri) {
            if (v < vertex_count) {
                ++first[welded[v] + 1];
            }
        }
    }
    for (std::size_t w = 0; w < representative.size(); ++w) {
        first[w + 1] += first[w];
    }
    std::vector<std::pair<std::uint32_t, std::uint8_t>> corners(first.back());
    std::vector<std::size_t> filled(first.begin(), first.end() - 1);
    for (std::size_t t = 0; t < triangle_count; ++t) {
        for (std::uint8_t corner = 0; corner < 3; ++corner) {
            const std::uint32_t v = mesh.triangles[t][corner];
            if (v < vertex_count) {
                corners[filled[welded[v]]++] = {static_cast<std::uint32_t>(t), corner};
            }
        }
    }

    // A corner's normal: the angle-weighted mean of the normals of the faces around its position
    // that meet its own face at no more than the crease angle (summed in triangle order, so a
    // position without creases gets compute_vertex_normals' bits).
    const double crease_cosine = std::cos(crease_angle);
    const auto corner_normal = [&](std::size_t t, std::uint32_t w) {
        Vec3d sum = Vec3d::Zero();
        Vec3d widest_normal = face_normal[t];
        double widest = -1.0;
        for (std::size_t i = first[w]; i < first[w + 1]; ++i) {
            const auto [other, corner] = corners[i];
            // At a crease angle of π every face counts, back-to-back ones too.
            if (crease_cosine > -1.0 && face_normal[other].dot(face_normal[t]) < crease_cosine) {
                continue;
            }
            const double angle = corner_angle[other][corner];
            sum += angle * face_normal[other];
            if (angle > widest) {
                widest = angle;
                widest_normal = face_normal[other];
            }
        }
        const double length = sum.norm();
        if (length > 1e-9 && std::isfinite(length)) {
            return Vec3f((sum / length).cast<float>());
        }
        return widest_normal.squaredNorm() > 0.0 ? Vec3f(widest_normal.cast<float>())
                                                 : Vec3f(0.0f, 0.0f, 1.0f);
    };

    // A vertex whose corners get different normals is split, one copy per normal.
    mesh.normals.assign(vertex_count, Vec3f(0.0f, 0.0f, 1.0f));
    std::vector<bool> assigned(vertex_count, false);
    std::vector<std::vector<std::uint32_t>> copies(vertex_count);
    const auto same = [](const Vec3f& a, const Vec3f& b) {
        return a.x() == b.x() && a.y() == b.y() && a.z() == b.z();
    };
    for (std::size_t t = 0; t < triangle_count; ++t) {
        for (std::size_t corner = 0; corner < 3; ++corner) {
            std::uint32_t& v = mesh.triangles[t][corner];
            if (v >= vertex_count || (v < given.size() && given[v])) {
                continue;
            }
            const Vec3f n = corner_normal(t, welded[v]);
            if (!assigned[v]) {
                assigned[v] = true;
                mesh.normals[v] = n;
                continue;
            }
            if (same(mesh.normals[v], n)) {
                continue;
            }
            const auto copy =
                std::find_if(copies[v].begin(), copies[v].end(),
                             [&](std::uint32_t c) { return same(mesh.normals[c], n); });
            if (copy != copies[v].end()) {
                v = *copy;
                continue;
            }
            const auto added = static_cast<std::uint32_t>(mesh.positions.size());
            mesh.positions.push_back(mesh.positions[v]);
            mesh.normals.push_back(n);
            if (mesh.has_uvs()) {
                mesh.uvs.push_back(mesh.uvs[v]);
            }
            copies[v].push_back(added);
            v = added;
        }
    }
}

std::size_t remove_degenerate_triangles(Mesh& mesh) {
    const std::size_t n = mesh.positions.size();
    const bool has_materials = !mesh.materials.empty();
    std::size_t kept = 0;
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
        const auto& t = mesh.triangles[i];
        const bool usable =
            indices_valid(t, n) &&
            area_vector(mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]);
        if (!usable) {
            continue;
        }
        mesh.triangles[kept] = t;
        if (has_materials && i < mesh.materials.size()) {
            mesh.materials[kept] = mesh.materials[i];
        }
        ++kept;
    }
    const std::size_t removed = mesh.triangles.size() - kept;
    mesh.triangles.resize(kept);
    if (has_materials) {
        mesh.materials.resize(std::min(kept, mesh.materials.size()));
    }
    return removed;
}

std::ostream& operator<<(std::ostream& os, const Mesh& m) {
    os << "mesh '" << m.name << "': " << m.positions.size() << " vertices, " << m.triangles.size()
       << " triangles" << (m.has_uvs() ? ", uvs" : ", no uvs");
    if (m.positions.empty()) {
        return os << ", empty bounds";
    }
    const Eigen::AlignedBox3f b = m.bounds();
    const auto point = [&os](const Vec3f& p) {
        os << '(' << p.x() << ", " << p.y() << ", " << p.z() << ')';
    };
    os << ", bounds ";
    point(b.min());
    os << " to ";
    point(b.max());
    return os;
}

}  // namespace mrt
