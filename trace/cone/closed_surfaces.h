#pragma once
// Which triangles of a hierarchy file bound a solid: the parts of each mesh that are closed,
// consistently wound surfaces once vertices at the same position are welded (UV and normal
// seams split vertices that are one point of the surface).
//
// Why the cone tracer needs it. A cone that covers part of a thin solid — a branch, the rim of
// a sphere — meets its front and its back over the same part of its footprint. The A-buffer
// composites fragments as independent layers, so the two coverages w make 1 − (1 − w)² ≈ 2w:
// thin solids twice as opaque as they are (measured: a plant's branches 1.3–2× too dark in
// cone and cone-classic alike). Along any line from a point outside a closed surface, each
// crossing out of it follows a crossing into it, so its back faces add nothing to what its
// front faces cover: a cone whose apex lies outside the surface's bounding box skips them.
// Open surfaces (leaves, a floor) are seen from both sides and are never skipped.

#include "common/hierarchy/hierarchy_file.h"
#include "common/math/math.h"

#include <array>
#include <cstdint>
#include <vector>

namespace mrt {

/// One closed, consistently wound surface of a mesh, in its object's space.
struct ClosedSurface {
    std::array<float, 3> lower;  ///< Its bounding box.
    std::array<float, 3> upper;
    /// +1 when the winding's normal (p1 − p0) × (p2 − p0) points out of the solid, −1 when in.
    float outward;
    /// A thousandth of the box's diagonal: rounding must not decide whether a cone that starts
    /// on a surface touching the solid sees it from outside.
    float slack;

    /// Whether `apex` lies outside the box by more than `margin` (the cone's starting radius)
    /// and the slack: then every back face of the surface is hidden behind a front face as
    /// seen from there.
    bool seen_from_outside(const Vec3f& apex, float margin) const {
        const float m = margin + slack;
        return apex.x() < lower[0] - m || apex.y() < lower[1] - m || apex.z() < lower[2] - m ||
               apex.x() > upper[0] + m || apex.y() > upper[1] + m || apex.z() > upper[2] + m;
    }
    /// Whether the plane through `point` with normal `normal` (any length; the winding's, or
    /// for a whole object the outward one) faces away from every point within `margin` of
    /// `apex`.
    bool back_facing(const Vec3f& point, const Vec3f& normal, const Vec3f& apex,
                     float margin) const {
        return back_facing(normal.dot(point - apex), normal.norm(), margin);
    }
    /// The same from n·(point − apex) and |n|, for a caller that has them (in a ray's frame).
    bool back_facing(float normal_dot_apart, float normal_length, float margin) const {
        return outward * normal_dot_apart > margin * normal_length;
    }
    /// Whether a cone along d goes into the solid through a primitive whose normal n (of length
    /// `normal_length`) has n·d = `normal_dot_direction`: against the outward normal by more
    /// than the cosine `margin`.
    bool entered_through(float normal_dot_direction, float normal_length, float margin) const {
        return outward * normal_dot_direction < -margin * normal_length;
    }
};

class ClosedSurfaces {
  public:
    /// Every mesh object of `view`; linear in its triangles.
    explicit ClosedSurfaces(const HierarchyView& view);

    /// The closed surface triangle `i` (into 'TRIS') lies on, or nullptr.
    const ClosedSurface* of_triangle(std::uint32_t i) const {
        const std::uint32_t s = m_triangle_surface[i];
        return s == kOpen ? nullptr : &m_surfaces[s];
    }
    /// For a mesh object made only of closed surfaces: their joint box and outward sign 1 (its
    /// points' normals point out of the solid), or nullptr. Its points can then be skipped
    /// where they face away from a cone's apex outside the box.
    const ClosedSurface* of_object(std::uint32_t object) const {
        const std::uint32_t s = m_object_surface[object];
        return s == kOpen ? nullptr : &m_surfaces[s];
    }
    std::size_t surface_count() const { return m_surfaces.size(); }

  private:
    static constexpr std::uint32_t kOpen = 0xffffffffu;
    std::vector<ClosedSurface> m_surfaces;
    std::vector<std::uint32_t> m_triangle_surface;
    std::vector<std::uint32_t> m_object_surface;
};

}  // namespace mrt
