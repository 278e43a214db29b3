#pragma once
// Lights made of geometry: faces whose material emits (an OBJ face with a non-zero `Ke`). A
// MeshAreaLight is one flat, connected region of such faces of one material, in world space,
// derived from the scene's geometry by emissive_lights (common/scene/emissive_lights.h) every
// time a scene is loaded, so that scene files and hierarchy files never store it twice.
// What each tracer does with one is in trace/render/mesh_light.h.

#include "common/math/math.h"

#include <array>
#include <vector>

namespace mrt {

/// A flat emitter made of triangles, emitting uniform radiance from the side its normal faces.
class MeshAreaLight {
  public:
    using Triangle = std::array<Vec3f, 3>;

    /// `triangles` (world space, at least one, all in one plane within rounding) emit `radiance`
    /// towards `normal` (unit; the side their counter-clockwise winding faces). Triangles of zero
    /// area are kept but never sampled.
    MeshAreaLight(std::vector<Triangle> triangles, const Vec3f& normal, const Rgb& radiance);

    const std::vector<Triangle>& triangles() const { return m_triangles; }
    const Vec3f& normal() const { return m_normal; }
    const Rgb& radiance() const { return m_radiance; }
    /// Total area of the triangles.
    float area() const { return m_area; }
    /// Area-weighted centre of the triangles.
    const Vec3f& centroid() const { return m_centroid; }
    /// The triangle a uniform number u ∈ [0, 1) picks, with probability proportional to its area,
    /// and u rescaled to [0, 1) within that triangle's share (so stratified u stays stratified).
    std::size_t pick_triangle(float& u) const;

  private:
    std::vector<Triangle> m_triangles;
    std::vector<float> m_cumulative_area;  ///< Running sum of areas, last element = m_area.
    Vec3f m_normal;
    Rgb m_radiance;
    float m_area = 0.0f;
    Vec3f m_centroid;
};

}  // namespace mrt
