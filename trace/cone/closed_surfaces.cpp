#include "trace/cone/closed_surfaces.h"

#include "common/math/position_weld.h"
#include "common/math/quantization.h"

#include <algorithm>
#include <bit>
#include <limits>
#include <numbers>
#include <numeric>
#include <unordered_map>

namespace mrt {

namespace {

/// Uses of one undirected edge: how many triangles, and the sum of their directions (+1 for
/// lower → higher welded vertex): a closed, consistently wound surface has 2 and 0.
struct EdgeUse {
    int triangles = 0;
    int direction = 0;
};

/// How much of the isoperimetric bound L² ≥ 4π·A a component's boundary (and inconsistently
/// wound edges, counted twice) may take for it to count as closed. Any sheet is open (≥ 1), a
/// hemisphere too (½); a sphere missing a cap of angular radius θ has (1 − cos θ)/2, so up to
/// 53° of it may be missing. The Stanford bunny, with the five holes in its base, has 0.16.
constexpr double kMaxHoleShare = 0.2;

/// A closed surface's rounding slack (ClosedSurface::slack), as a fraction of its box's diagonal:
/// far above float rounding of positions in the box (1e-7), far below any gap a cone could
/// start in and still be meant to see the solid from outside.
constexpr double kSlackFraction = 1e-3;

/// An object's vertex normals count as pointing out of its solids when the triangles whose
/// normals point in hold at most this share of its area: a few stray normals (at a crease) are
/// tolerated, a mesh whose normals all point in is not.
constexpr double kMaxInwardNormalShare = 0.01;

ClosedSurface surface(const Eigen::AlignedBox3d& box, float outward) {
    const Eigen::Vector3f lower = box.min().cast<float>();
    const Eigen::Vector3f upper = box.max().cast<float>();
    return {{lower.x(), lower.y(), lower.z()},
            {upper.x(), upper.y(), upper.z()},
            outward,
            static_cast<float>(kSlackFraction * box.diagonal().norm())};
}

std::uint32_t find(std::vector<std::uint32_t>& parent, std::uint32_t i) {
    while (parent[i] != i) {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    return i;
}

}  // namespace

ClosedSurfaces::ClosedSurfaces(const HierarchyView& view)
    : m_triangle_surface(view.triangles.size(), kOpen),
      m_object_surface(view.objects.size(), kOpen) {
    std::unordered_map<std::uint64_t, EdgeUse> edges;
    std::vector<std::uint32_t> vertex_of;  // per welded id: one of its vertices
    std::vector<std::uint32_t> parent;     // union-find over welded ids
    for (std::size_t o = 0; o < view.objects.size(); ++o) {
        const HierarchyObject& object = view.objects[o];
        if (object.kind != HierarchyObjectKind::Mesh || object.triangle_count == 0) {
            continue;
        }
        const std::vector<std::uint32_t> weld = weld_positions(
            object.vertex_count,
            [&](std::size_t v) {
                const auto& p = view.vertex_positions[object.first_vertex + v];
                return Vec3f(p[0], p[1], p[2]);
            },
            vertex_of);
        const std::size_t welded = vertex_of.size();
        parent.resize(welded);
        std::iota(parent.begin(), parent.end(), 0u);
        edges.clear();
        const auto ids = [&](std::uint32_t t) {
            const auto& tri = view.triangles[object.first_triangle + t];
            return std::array<std::uint32_t, 3>{weld[tri[0] - object.first_vertex],
                                                weld[tri[1] - object.first_vertex],
                                                weld[tri[2] - object.first_vertex]};
        };
        const auto degenerate = [](const std::array<std::uint32_t, 3>& w) {
            return w[0] == w[1] || w[1] == w[2] || w[2] == w[0];
        };
        for (std::uint32_t t = 0; t < object.triangle_count; ++t) {
            const auto w = ids(t);
            if (degenerate(w)) {
                continue;  // welded to a line or a point (a sphere's pole): no area, no edge
            }
            for (std::size_t e = 0; e < 3; ++e) {
                const std::uint32_t a = w[e];
                const std::uint32_t b = w[(e + 1) % 3];
                EdgeUse& use =
                    edges[(static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b)];
                ++use.triangles;
                use.direction += a < b ? 1 : -1;
                parent[find(parent, a)] = find(parent, b);
            }
        }
        // A component is closed when each of its edges has two triangles, wound oppositely —
        // up to small holes: scanned meshes (the Stanford bunny) have some where the scanner
        // saw nothing, through which a cone would see a few back faces it now skips. Small by
        // the isoperimetric inequality: any sheet's boundary has L² ≥ 4π·A (a hemisphere's
        // 2π·A), holes of a closed surface far less.
        std::vector<double> boundary(welded, 0.0);
        std::vector<double> area(welded, 0.0);
        const auto position = [&](std::uint32_t welded_id) {
            const auto& q = view.vertex_positions[object.first_vertex + vertex_of[welded_id]];
            return Eigen::Vector3d(q[0], q[1], q[2]);
        };
        for (const auto& [key, use] : edges) {
            if (use.triangles != 2 || use.direction != 0) {
                const auto a = static_cast<std::uint32_t>(key >> 32);
                const auto b = static_cast<std::uint32_t>(key & 0xffffffffu);
                boundary[find(parent, a)] += static_cast<double>(use.triangles == 2 ? 2 : 1) *
                                             (position(a) - position(b)).norm();
            }
        }
        for (std::uint32_t t = 0; t < object.triangle_count; ++t) {
            const auto w = ids(t);
            if (!degenerate(w)) {
                area[find(parent, w[0])] +=
                    0.5 *
                    (position(w[1]) - position(w[0])).cross(position(w[2]) - position(w[0])).norm();
            }
        }
        std::vector<bool> open(welded, false);
        for (std::size_t r = 0; r < welded; ++r) {
            open[r] = boundary[r] * boundary[r] > kMaxHoleShare * 4.0 * std::numbers::pi * area[r];
        }
        // Boxes and signed volumes (Σ p0 · (p1 × p2), six times the volume) per component.
        struct Accumulated {
            Eigen::AlignedBox3d box;
            double volume = 0.0;
        };
        std::unordered_map<std::uint32_t, Accumulated> components;
        bool all_closed = true;
        for (std::uint32_t t = 0; t < object.triangle_count; ++t) {
            const auto w = ids(t);
            if (degenerate(w)) {
                continue;
            }
            const std::uint32_t root = find(parent, w[0]);
            if (open[root]) {
                all_closed = false;
                continue;
            }
            const auto& tri = view.triangles[object.first_triangle + t];
            std::array<Eigen::Vector3d, 3> p;
            for (std::size_t i = 0; i < 3; ++i) {
                const auto& q = view.vertex_positions[tri[i]];
                p[i] = Eigen::Vector3d(q[0], q[1], q[2]);
            }
            Accumulated& c = components[root];
            for (const auto& q : p) {
                c.box.extend(q);
            }
            c.volume += p[0].dot(p[1].cross(p[2]));
        }
        std::unordered_map<std::uint32_t, std::uint32_t> surface_of;
        Eigen::AlignedBox3d object_box;
        for (const auto& [root, c] : components) {
            if (!(c.volume != 0.0) || !std::isfinite(c.volume)) {
                all_closed = false;
                continue;  // flat or damaged: no inside to speak of
            }
            surface_of[root] = static_cast<std::uint32_t>(m_surfaces.size());
            m_surfaces.push_back(surface(c.box, c.volume > 0.0 ? 1.0f : -1.0f));
            object_box.extend(c.box);
        }
        // Whether the vertex normals (which the points' normals come from) point out of the
        // solids, by area: a mesh whose normals point in would lose its front points.
        double agreeing = 0.0;
        double disagreeing = 0.0;
        for (std::uint32_t t = 0; t < object.triangle_count; ++t) {
            const auto w = ids(t);
            if (degenerate(w)) {
                continue;
            }
            const auto it = surface_of.find(find(parent, w[0]));
            if (it == surface_of.end()) {
                continue;
            }
            m_triangle_surface[object.first_triangle + t] = it->second;
            const auto& tri = view.triangles[object.first_triangle + t];
            const auto at = [&](std::size_t i) {
                const auto& q = view.vertex_positions[tri[i]];
                return Vec3f(q[0], q[1], q[2]);
            };
            const Vec3f outward =
                m_surfaces[it->second].outward * (at(1) - at(0)).cross(at(2) - at(0));
            const Vec3f normals = decode_normal(view.vertex_normals[tri[0]]) +
                                  decode_normal(view.vertex_normals[tri[1]]) +
                                  decode_normal(view.vertex_normals[tri[2]]);
            (outward.dot(normals) > 0.0f ? agreeing : disagreeing) += outward.norm();
        }
        if (all_closed && !surface_of.empty() &&
            disagreeing <= kMaxInwardNormalShare * (agreeing + disagreeing)) {
            // Its points' normals point out of the solid: the object's entry says +1.
            m_object_surface[o] = static_cast<std::uint32_t>(m_surfaces.size());
            m_surfaces.push_back(surface(object_box, 1.0f));
        }
    }
}

}  // namespace mrt
