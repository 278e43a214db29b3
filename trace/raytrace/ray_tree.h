#pragma once
// The recursive ray tree both baselines trace (Whitted 1980; Cook et al. 1984): Phong shading
// with shadow rays, mirror reflection and refraction weighted by the material coefficients,
// total internal reflection, a depth limit and weight-based pruning. What differs between the
// two is only how each light and each secondary direction is chosen, so that is a policy:
//
// - CentreSampling (whitted): area lights' exact unoccluded irradiance and highlight from their
//   whole extent, times a hard shadow towards their centres; mirror and refraction directions
//   exactly (roughness ignored).
// - StochasticSampling (distributed): one uniform point on each area light, elliptical or made of
//   emissive faces (soft shadows), reflected and refracted directions spread by the material
//   roughness (glossy).
//
// Emissive faces (Material::emission) are seen as what they emit from their front, and light the
// scene as Scene::mesh_lights. A shadow ray towards a point of such a light stops short of it
// (kEmitterShadowReach), so that the emitter's own faces do not shadow it.

#include "common/footprint/footprint.h"
#include "common/math/sampling.h"
#include "common/scene/scene.h"
#include "common/system/check.h"
#include "common/texture/texture.h"
#include "trace/bvh/cutouts.h"
#include "trace/bvh/scene_bvh.h"
#include "trace/raytrace/surface_point.h"
#include "trace/render/area_light.h"
#include "trace/render/mesh_light.h"
#include "trace/render/render.h"
#include "trace/render/scattering.h"
#include "trace/render/shading.h"

#include <algorithm>
#include <cmath>
#include <optional>

namespace mrt {

struct CentreSampling {
    /// Area lights give their exact unoccluded irradiance and highlight
    /// (trace/render/area_light.h), times the hard shadow towards their centre.
    static constexpr bool kWholeAreaLights = true;
    LightSample area_light(const EllipticalAreaLight& light, const Vec3f& p) const {
        return sample_area_light_centre(light, p);
    }
    LightSample mesh_light(const MeshAreaLight& light, const Vec3f& p) const {
        return sample_mesh_light_centre(light, p);
    }
    Vec3f spread(const Vec3f& direction, float /*roughness*/) const { return direction; }
};

class StochasticSampling {
  public:
    static constexpr bool kWholeAreaLights = false;
    explicit StochasticSampling(StratifiedSampler& sampler) : m_sampler(sampler) {}

    LightSample area_light(const EllipticalAreaLight& light, const Vec3f& p) {
        const Vec2f u = m_sampler.next_2d();
        return sample_area_light(light, p, u.x(), u.y());
    }
    LightSample mesh_light(const MeshAreaLight& light, const Vec3f& p) {
        const Vec2f u = m_sampler.next_2d();
        return sample_mesh_light(light, p, u.x(), u.y());
    }
    Vec3f spread(const Vec3f& direction, float roughness) {
        if (!(roughness > 0.0f)) {
            return direction;
        }
        const Vec2f u = m_sampler.next_2d();
        return gaussian_spread_direction(direction, roughness, u.x(), u.y());
    }

  private:
    StratifiedSampler& m_sampler;
};

/// The mirror reflection at a hit: its direction and the normal (with derivatives) it mirrors
/// about. That is the shading normal, unless an interpolated normal would mirror the ray below
/// the geometric surface; there the flat triangle's own mirror direction is the right one
/// (`about_geometric`), and its normal does not vary.
struct Mirror {
    Vec3f direction;
    Vec3f normal;
    Vec3f dn_dx;
    Vec3f dn_dy;
    bool about_geometric = false;
};

inline Mirror mirror_at(const Vec3f& d, const SurfacePoint& sp, const SurfaceDifferential& s) {
    const Vec3f r = reflect(d, sp.shading_normal);
    if (r.dot(sp.geometric_normal) > 0.0f) {
        return {r, sp.shading_normal, s.dn_dx, s.dn_dy, false};
    }
    return {reflect(d, sp.geometric_normal), sp.geometric_normal, Vec3f::Zero(), Vec3f::Zero(),
            true};
}

/// What a ray carries for texture filtering (Igehy §4): its differentials, and for the
/// `distance` filter the distance travelled before its origin and the camera's angular pixel
/// spread. Rays without one (filter `none`, untextured scenes) skip the footprint work.
struct RayFootprint {
    RayDifferential differential;
    float distance = 0.0f;
    float spread = 0.0f;

    /// A camera ray's footprint.
    static RayFootprint camera(const RayDifferential& differential) {
        return {differential, 0.0f, std::max(differential.dd_dx.norm(), differential.dd_dy.norm())};
    }
};

/// The cosine of incidence below which the `distance` texture filter stops widening the footprint
/// by 1/cos. It only keeps the width finite for a ray parallel to the surface: at 1e-3 (89.94°)
/// the width is already a thousand times the face-on one.
inline constexpr float kMinimumFootprintCosine = 1e-3f;

/// The share of its length a shadow ray towards a point on an emissive face travels: the point is
/// on the emitter's own faces, which must not shadow it (1e-4 is far above float rounding of a
/// hit distance, and far below any gap between an emitter and what could stand in front of it).
inline constexpr float kEmitterShadowReach = 1.0f - 1e-4f;

/// Pixel differentials shrink with the samples sharing a pixel, but never below an eighth of a
/// pixel, so textures are not under-filtered at high sample counts (pbrt-v4's rule).
inline float footprint_scale(int samples_per_pixel) {
    return std::max(0.125f, 1.0f / std::sqrt(static_cast<float>(std::max(1, samples_per_pixel))));
}

template <typename Sampling>
class RayTree {
  public:
    RayTree(const Scene& scene, const SceneBvh& bvh, const TextureSampler& textures, int max_depth,
            Differentials differentials = Differentials::WhenRead)
        : m_scene(scene),
          m_bvh(bvh),
          m_textures(textures),
          m_cutouts(scene, textures),
          m_max_depth(max_depth),
          m_always_carry(differentials == Differentials::Always) {}

    /// Radiance arriving along `ray` (reflection/refraction depth `depth` so far; `weight` is
    /// the product of the coefficients that scale this ray's contribution to the pixel).
    Rgb radiance(const Ray& ray, int depth, RayCounters& counters, Sampling& sampling,
                 float weight = 1.0f, const RayFootprint* footprint = nullptr) const;

    /// Radiance along a camera ray; `differential()` gives the ray's differential and is called
    /// only when footprints are wanted (a texture filter that reads them, and a texture).
    template <typename DifferentialFunction>
    Rgb camera_radiance(const Ray& ray, DifferentialFunction&& differential, RayCounters& counters,
                        Sampling& sampling) const {
        if (!m_always_carry &&
            (m_textures.filter() == TextureFilter::None || m_scene.textures.empty())) {
            return radiance(ray, 0, counters, sampling);
        }
        const RayFootprint footprint = RayFootprint::camera(differential());
        return radiance(ray, 0, counters, sampling, 1.0f, &footprint);
    }

  private:
    /// The scene's cut-outs for the BVH's queries, null where it has none.
    const SceneCutouts* cutouts() const { return m_cutouts.empty() ? nullptr : &m_cutouts; }

    Rgb direct_light(const SurfacePoint& sp, const Material& material, const Rgb& albedo,
                     const Vec3f& wo, RayCounters& counters, Sampling& sampling) const;

    const Scene& m_scene;
    const SceneBvh& m_bvh;
    const TextureSampler& m_textures;
    const SceneCutouts m_cutouts;
    int m_max_depth;
    bool m_always_carry;
};

template <typename Sampling>
Rgb RayTree<Sampling>::direct_light(const SurfacePoint& sp, const Material& material,
                                    const Rgb& albedo, const Vec3f& wo, RayCounters& counters,
                                    Sampling& sampling) const {
    Rgb sum = Rgb::Zero();
    const auto add = [&](const LightSample& light) {
        // Lights below the geometric surface never reach it, whatever the shading normal says.
        const float cos_geometric = sp.geometric_normal.dot(light.wi);
        const float cos_shading = sp.shading_normal.dot(light.wi);
        if (cos_geometric <= 0.0f || cos_shading <= 0.0f || (light.irradiance <= 0.0f).all()) {
            return;
        }
        ++counters.shadow;
        const Ray shadow{sp.spawn_origin(light.wi), light.wi, light.distance};
        if (m_bvh.occluded(shadow, cutouts())) {
            return;
        }
        sum += light.irradiance * cos_shading *
               phong_brdf(material, albedo, sp.shading_normal, light.wi, wo);
    };
    for (const PointLight& light : m_scene.point_lights) {
        add(sample_point_light(light, sp.position));
    }
    for (const EllipticalAreaLight& light : m_scene.area_lights) {
        if constexpr (Sampling::kWholeAreaLights) {
            const LightSample centre = sampling.area_light(light, sp.position);
            if (sp.geometric_normal.dot(centre.wi) <= 0.0f) {
                continue;  // the shadow ray to the centre would start into the surface
            }
            const Rgb unoccluded =
                area_light_unoccluded(light, sp.position, sp.shading_normal, wo, material, albedo);
            if (!(unoccluded.maxCoeff() > 0.0f)) {
                continue;
            }
            ++counters.shadow;
            if (m_bvh.occluded(Ray{sp.spawn_origin(centre.wi), centre.wi, centre.distance},
                               cutouts())) {
                continue;
            }
            sum += unoccluded;
        } else {
            add(sampling.area_light(light, sp.position));
        }
    }
    for (const MeshAreaLight& light : m_scene.mesh_lights) {
        LightSample sample = sampling.mesh_light(light, sp.position);
        sample.distance *= kEmitterShadowReach;
        if constexpr (Sampling::kWholeAreaLights) {
            if (sp.geometric_normal.dot(sample.wi) <= 0.0f) {
                continue;  // the shadow ray to the centre would start into the surface
            }
            const Rgb unoccluded =
                mesh_light_unoccluded(light, sp.position, sp.shading_normal, wo, material, albedo);
            if (!(unoccluded.maxCoeff() > 0.0f)) {
                continue;
            }
            ++counters.shadow;
            if (m_bvh.occluded(Ray{sp.spawn_origin(sample.wi), sample.wi, sample.distance},
                               cutouts())) {
                continue;
            }
            sum += unoccluded;
        } else {
            add(sample);
        }
    }
    return sum;
}

template <typename Sampling>
Rgb RayTree<Sampling>::radiance(const Ray& ray, int depth, RayCounters& counters,
                                Sampling& sampling, float weight,
                                const RayFootprint* footprint) const {
    SceneHit hit;
    if (!m_bvh.intersect(ray, hit, cutouts())) {
        return m_scene.background;
    }
    const Vec3f d = ray.direction.normalized();
    const SurfacePoint sp = make_surface_point(m_scene, hit, d);
    MRT_DCHECK(sp.material < m_scene.materials.size());
    MRT_DCHECK(std::isfinite(weight) && weight > 0.0f);
    const Material& material = m_scene.materials[sp.material];
    const Vec3f wo = -d;

    // The footprint at the hit: transferred differentials and the surface's derivatives, only
    // when a texture here or a reflected or refracted ray reads them.
    const bool spawns =
        depth < m_max_depth && (material.reflectivity > 0.0f || material.refracts());
    if (material.texture < 0 && !spawns && !m_always_carry) {
        footprint = nullptr;
    }
    RayDifferential at_hit;
    SurfaceDifferential surface;
    float travelled = 0.0f;
    if (footprint != nullptr) {
        const float t = hit.t * ray.direction.norm();
        travelled = footprint->distance + t;
        at_hit = footprint->differential.transfer(d, t, sp.geometric_normal);
        surface = make_surface_differential(m_scene, hit, sp, at_hit.dp_dx, at_hit.dp_dy);
    }

    // Light not mirrored or transmitted is scattered locally (ambient + Phong).
    const float local_weight = local_share(material.reflectivity, material.transparency);
    Rgb albedo;
    if (footprint != nullptr && material.texture >= 0) {
        UvFootprint uv_footprint{surface.duv_dx, surface.duv_dy};
        if (m_textures.filter() == TextureFilter::Distance) {
            // Igehy Fig. 3b: the width the pixel cone has after the distance travelled, spread
            // over the surface by the angle of incidence, isotropic in texture space.
            const float cosine =
                std::max(std::abs(d.dot(sp.geometric_normal)), kMinimumFootprintCosine);
            const float width = travelled * footprint->spread / cosine * surface.uv_per_length;
            uv_footprint = {Vec2f(width, 0.0f), Vec2f(0.0f, width)};
        }
        albedo = m_textures.diffuse(material, sp.uv, uv_footprint) * local_weight;
    } else {
        albedo = m_textures.diffuse(material, sp.uv) * local_weight;
    }
    Rgb result =
        m_scene.ambient * albedo + direct_light(sp, material, albedo, wo, counters, sampling);
    if (sp.entering) {
        result += material.emission;
    }
    if (depth >= m_max_depth) {
        return result;
    }

    const float eta = sp.entering ? 1.0f / material.ior : material.ior;
    const std::optional<Vec3f> transmitted =
        material.refracts() ? refract(d, sp.shading_normal, eta) : std::nullopt;
    // Total internal reflection: the transmitted share is mirrored instead.
    const BranchWeights branches = branch_weights(material.reflectivity, material.transparency,
                                                  transmitted.has_value() ? 1.0f : 0.0f);
    // A secondary ray along `direction`, carrying the differential `child()` when footprints are.
    const auto branch = [&](const Vec3f& direction, float branch_weight, const auto& child) {
        ++counters.secondary;
        const Ray secondary{sp.spawn_origin(direction), direction, kInfinity};
        RayFootprint child_footprint;
        if (footprint != nullptr) {
            child_footprint = {child(), travelled, footprint->spread};
        }
        return radiance(secondary, depth + 1, counters, sampling, branch_weight,
                        footprint != nullptr ? &child_footprint : nullptr);
    };
    const auto refracted = [&](float branch_weight) {
        const Vec3f direction = fold_to_side(sampling.spread(*transmitted, material.roughness),
                                             sp.geometric_normal, Side::Below);
        return branch(direction, branch_weight, [&] {
            return at_hit.refract(d, sp.shading_normal, surface.dn_dx, surface.dn_dy, eta);
        });
    };
    const auto reflected = [&](float branch_weight) {
        const Mirror mirror = mirror_at(d, sp, surface);
        const Vec3f direction = fold_to_side(sampling.spread(mirror.direction, material.roughness),
                                             sp.geometric_normal, Side::Above);
        return branch(direction, branch_weight,
                      [&] { return at_hit.reflect(d, mirror.normal, mirror.dn_dx, mirror.dn_dy); });
    };
    return add_branches(result, weight, branches, refracted, reflected);
}

}  // namespace mrt
