#pragma once
// What the cone tracer's A-buffer (trace/cone/abuffer.h) accumulates per fragment: the surface
// attributes of the points and triangles a ray cone meets, weight-summed and averaged for the
// shader (Wand & Straßer §4.4). World space throughout: instanced objects' attributes are
// mapped out of their object space before they are inserted.
//
// The normal's derivative (the shape operator, for reflected and refracted cones) is not
// averaged: the paper's "cheaper alternative is to neglect aliasing of the surface derivatives
// ... and to use nearest neighbor sampling for the differential properties". The fragment keeps
// the operator of its largest-weight contributor.

#include "common/math/math.h"
#include "trace/cone/highlight_mixture.h"

#include <algorithm>
#include <array>
#include <ostream>

namespace mrt {

struct ConeSurface {
    Vec3f normal = Vec3f::Zero();  ///< Unit normal of one contributor; Σ w·n in the sums.
    Rgb diffuse = Rgb::Zero();     ///< Diffuse albedo, texture included (linear).
    Rgb specular = Rgb::Zero();
    Rgb emission = Rgb::Zero();  ///< Radiance emitted from the front (Material::emission).
    float phong_exponent = 0.0f;
    float reflectivity = 0.0f;
    float transparency = 0.0f;
    float roughness = 0.0f;
    /// Index of refraction, weighted by transparency·weight so that opaque contributors (whose
    /// index means nothing) do not dilute a glass surface's.
    float ior = 0.0f;
    /// World-space shape operator: dn = shape·dp for a displacement dp in the tangent plane.
    /// Nearest-neighbour: that of the contributor with the largest weight `shape_weight`.
    Mat3f shape = Mat3f::Zero();
    float shape_weight = 0.0f;
    /// Set by averaged(): the length of the weighted mean normal, 1 where the contributors
    /// agree and less where the normals across the footprint spread (Toksvig 2005).
    float normal_length = 1.0f;
    /// Each contributor's own highlight from the scene's first lights (HighlightLights::at):
    /// their mixture, which the shader prefers to the mean normal's lobe where they differ.
    std::array<float, kHighlightLights> highlights{};
    /// The angular variance the turn of the normals across the footprint adds to the highlight's
    /// lobe (mirror_spread): a triangle's, whose one interpolated normal at the axis stands for
    /// a footprint over which it may turn by more than the lobe is wide. 0 for points, whose
    /// normals' spread is their length. Averaged.
    float lobe_spread = 0.0f;

    void add(const ConeSurface& p, float weight) {
        add_weighted(p, weight);
        if (weight > shape_weight) {
            shape_weight = weight;
            shape = p.shape;
        }
    }

    /// A contribution whose shape operator is computed only if it becomes the fragment's:
    /// nearly all insertions merge into a fragment that already holds a heavier one (98 % on
    /// the complex scene), and the world-space operator costs two 3×3 products.
    template <class ShapeOf>
    struct Lazy {
        const ConeSurface& surface;  ///< Its attributes; `shape` is not read.
        ShapeOf shape_of;            ///< () → Mat3f, the world-space shape operator.
    };

    template <class ShapeOf>
    void add(const Lazy<ShapeOf>& p, float weight) {
        add_weighted(p.surface, weight);
        if (weight > shape_weight) {
            shape_weight = weight;
            shape = p.shape_of();
        }
    }

    /// Every field's weighted sum but the shape operator's.
    void add_weighted(const ConeSurface& p, float weight) {
        normal += weight * p.normal;
        diffuse += weight * p.diffuse;
        specular += weight * p.specular;
        emission += weight * p.emission;
        phong_exponent += weight * p.phong_exponent;
        reflectivity += weight * p.reflectivity;
        transparency += weight * p.transparency;
        roughness += weight * p.roughness;
        ior += weight * p.transparency * p.ior;
        lobe_spread += weight * p.lobe_spread;
        for (std::size_t l = 0; l < kHighlightLights; ++l) {
            highlights[l] += weight * p.highlights[l];
        }
    }

    void merge(const ConeSurface& o) {
        normal += o.normal;
        diffuse += o.diffuse;
        specular += o.specular;
        emission += o.emission;
        phong_exponent += o.phong_exponent;
        reflectivity += o.reflectivity;
        transparency += o.transparency;
        roughness += o.roughness;
        ior += o.ior;
        lobe_spread += o.lobe_spread;
        for (std::size_t l = 0; l < kHighlightLights; ++l) {
            highlights[l] += o.highlights[l];
        }
        if (o.shape_weight > shape_weight) {
            shape_weight = o.shape_weight;
            shape = o.shape;
        }
    }

    ConeSurface averaged(float weight) const {
        ConeSurface a = *this;
        const float inverse = 1.0f / weight;
        const float length = normal.norm();
        a.normal = length > 0.0f ? Vec3f(normal / length) : Vec3f::Zero();
        a.normal_length = std::min(1.0f, length * inverse);
        a.diffuse = diffuse * inverse;
        a.specular = specular * inverse;
        a.emission = emission * inverse;
        a.phong_exponent = phong_exponent * inverse;
        a.reflectivity = reflectivity * inverse;
        a.transparency = transparency * inverse;
        a.roughness = roughness * inverse;
        a.ior = transparency > 0.0f ? ior / transparency : 1.0f;
        a.lobe_spread = lobe_spread * inverse;
        for (float& h : a.highlights) {
            h *= inverse;
        }
        return a;
    }
};

/// The attributes of a shadow cone's fragments: none; only their weights (opacity) count.
struct ConeOpacity {
    void add(const ConeOpacity& /*point*/, float /*weight*/) {}
    void merge(const ConeOpacity& /*other*/) {}
    ConeOpacity averaged(float /*weight*/) const { return {}; }
};

inline std::ostream& operator<<(std::ostream& os, const ConeSurface& s) {
    return os << "ConeSurface{normal (" << s.normal.x() << ", " << s.normal.y() << ", "
              << s.normal.z() << "), diffuse (" << s.diffuse[0] << ", " << s.diffuse[1] << ", "
              << s.diffuse[2] << "), reflectivity " << s.reflectivity << ", transparency "
              << s.transparency << ", ior " << s.ior << '}';
}

}  // namespace mrt
