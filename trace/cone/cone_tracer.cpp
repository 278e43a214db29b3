#include "trace/cone/cone_tracer.h"

#include "common/footprint/footprint.h"
#include "common/footprint/point_weight.h"
#include "common/system/check.h"
#include "trace/cone/abuffer.h"
#include "trace/cone/cone_surface.h"
#include "trace/cone/light_share.h"
#include "trace/render/area_light.h"
#include "trace/render/camera_rays.h"
#include "trace/render/film.h"
#include "trace/render/method.h"
#include "trace/render/pixel_contrast.h"
#include "trace/render/pixel_filter.h"
#include "trace/render/scattering.h"
#include "trace/render/shading.h"

#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <limits>
#include <mutex>
#include <optional>
#include <ostream>
#include <thread>
#include <vector>

namespace mrt {

namespace {

using Clock = std::chrono::steady_clock;

/// How far past its start a cone leaving a surface is still taken to see that surface: half the
/// clip radius of its widened Gaussian over the sine of its elevation above the tangent plane,
/// never below a tenth (grazing cones would otherwise start arbitrarily far out). The rays the
/// cone stands for start all over its footprint on the surface, not at its apex, and the surface
/// itself is skipped by the traversal's own test; a larger clearance only skips what stands next
/// to the surface. At 1.5 clip radii a shadow cone from an out-of-focus fragment (a wide start)
/// started beyond the sphere beside it and lit its shadow: depth of field's RMSE was 0.0379,
/// at 0.5 it is 0.0263 (docs/cone-tracer.md).
constexpr float kSelfIntersectionFactor = 0.5f;
constexpr float kMinimumElevation = 0.1f;
/// The same for shadow cones, which start from the fragment's mean depth with no allowance for
/// its depth interval. Anything they skip near their start is an occluder they miss: with the
/// secondary cones' clearance plus the interval, a shadow cone from a floor beside a sphere
/// standing on it started inside the sphere and saw a light shut in it (mean 0.176 against
/// 0.117 at 32², 0.121 with this). The surface a cone leaves is skipped by the traversal itself.
constexpr float kShadowSelfIntersectionFactor = 0.02f;

/// A shadow cone to an area light whose centre lies below the tangent plane (the light straddles
/// it) is started as if the centre were this cosine above it. The value only has to be positive:
/// start_clearance treats every elevation below kMinimumElevation alike.
constexpr float kGrazingLightCosine = 1e-3f;

/// The index of refraction a fragment's averaged index is floored to, so that 1/η stays finite.
/// Scenes give indices ≥ 1 or near it; one of 1e-3 already totally reflects all but nearly normal
/// rays.
constexpr float kMinimumIor = 1e-3f;

/// A refraction counts as straddling the critical angle (ConeRenderStats) when neither share of
/// the footprint is below this: erfc's tails would otherwise count nearly every refraction.
constexpr float kStraddleShare = 1e-3f;

/// A shadow cone ends this fraction of the way to its light. At the light itself the footprint
/// of a cone to a point light is zero (it shrinks linearly to nothing there), a Gaussian no
/// weight is defined for, and whatever the light sits on (a lamp's fitting, a ceiling around an
/// area light) lies at that depth; a thousandth short, the footprint is a thousandth of the
/// hit's and that surface is left out.
constexpr float kShadowEndFraction = 0.999f;

/// The depth of focus along a primary ray is the focal distance over the cosine between the ray
/// and the camera's axis; the floor only keeps it finite for a ray at right angles to the axis,
/// which no frame narrower than 179.8° has.
constexpr float kMinimumForwardCosine = 1e-3f;

/// How far from 1 the squared length of a vector the shader takes for unit may be (checked in
/// Debug builds): normalised in float it is a few ulps off; a thousandth catches one that was
/// never normalised, or a zero sum of normals divided by its own rounding noise.
constexpr float kUnitTolerance = 1e-3f;

bool is_unit(const Vec3f& v) {
    return std::abs(v.squaredNorm() - 1.0f) <= kUnitTolerance;
}

float start_clearance(const Mat2f& start_footprint, float elevation, float half_interval,
                      float factor = kSelfIntersectionFactor) {
    const float radius = std::sqrt(FootprintCone::ellipse_of(start_footprint).major);
    return factor * std::sqrt(kPointWeightClipExponent) * radius /
               std::max(std::abs(elevation), kMinimumElevation) +
           half_interval;
}

/// The narrowest primary cone, radians: some hundred float roundings of a direction, far below
/// any pixel of a real image (a 512-pixel frame of 42° has 1.4e-3 rad per pixel).
constexpr float kMinimumSpread = 1e-5f;

/// The widest primary cone, radians: beyond a few degrees the cone's first-order footprint no
/// longer describes what its pixel sees (a 1×1 image of a 42° frame gave 0.157 against the
/// frame's mean 0.296), so such a pixel is traced as a grid of narrower cones.
constexpr float kMaximumPrimaryAngle = 0.035f;

/// At most this many sub-cones along each side of a pixel: 4096 cones bound what a frame of
/// nearly 180° costs per pixel, where the cones' first-order footprint is already far off anyway.
constexpr int kMaximumPrimaryCells = 64;

/// One of the cones a wide pixel is split into: its offset from the pixel centre, in pixels, and
/// its share of the pixel (the filter's weight there, normalised over the grid).
struct SubCone {
    float dx = 0.0f;
    float dy = 0.0f;
    float share = 1.0f;
};

/// How a pixel is split into sub-cones: `cells` × `cells` over the filter's support
/// [−radius, radius]², each cell `cell` pixels wide with the cone width `scale` of its box; the
/// cells the filter weighs, the same for every pixel.
struct PrimarySplit {
    int cells = 1;
    float cell = 1.0f;
    float scale = 1.0f;
    std::vector<SubCone> cones;
};

PrimarySplit primary_split(const CameraRays& camera, const PixelFilter& filter, float scale) {
    const float step = std::max(camera.pixel_step_x().norm(), camera.pixel_step_y().norm());
    // The angle of the pixel at the image centre, in the cone's own units of width.
    const float angle = 2.0f * std::atan(0.5f * step) * scale;
    PrimarySplit split;
    if (!(angle > kMaximumPrimaryAngle)) {
        return split;
    }
    const float support = 2.0f * filter.radius;
    split.cells =
        static_cast<int>(std::min(static_cast<float>(kMaximumPrimaryCells),
                                  std::ceil(support * angle / (scale * kMaximumPrimaryAngle))));
    split.cell = support / static_cast<float>(split.cells);
    split.scale = cone_pixel_scale(PixelFilter::box()) * split.cell;
    float weight_sum = 0.0f;
    for (int j = 0; j < split.cells; ++j) {
        for (int i = 0; i < split.cells; ++i) {
            const float dx = (static_cast<float>(i) + 0.5f) * split.cell - filter.radius;
            const float dy = (static_cast<float>(j) + 0.5f) * split.cell - filter.radius;
            const float w = filter.weight(dx, dy);
            if (w > 0.0f) {
                split.cones.push_back({dx, dy, w});
                weight_sum += w;
            }
        }
    }
    MRT_CHECK(weight_sum > 0.0f);
    for (SubCone& cone : split.cones) {
        cone.share /= weight_sum;
    }
    return split;
}

/// The fastest a secondary cone's footprint may widen, per unit of distance (the largest
/// singular value of its growth): beyond some tens of degrees the first-order footprint no
/// longer describes the rays it stands for (the reason primary cones are split at
/// kMaximumPrimaryAngle), and near the critical angle a refracted cone's growth has no bound
/// at all (2·10⁵ out of a glass bunny: a cone over the whole sphere of directions, which met
/// nothing and showed the background). Chosen on the field's bunnies (display RMSE 0.0834 with
/// no bound; 2: 0.0812, 1: 0.0799, 0.5: 0.0781, 0.25: 0.0772), where the other scenes did not
/// change or improved; 0.5 stays well clear of the narrow cones the first order describes.
constexpr float kMaximumSecondaryGrowth = 0.5f;

/// A cone inside a solid that met nothing is traced again with its start and its growth scaled
/// by this (ConeTracer::inside_radiance): narrow enough that its footprint lies inside the
/// solid it is in. On the field a tenth and a hundredth gave the same image to three digits;
/// a tenth keeps the points it meets coarser.
constexpr float kInsideRetraceScale = 0.1f;

/// Per-thread accumulators.
struct ConeWork {
    ConeRenderStats stats;
    RayCounters rays;
};

class ConeTracer {
  public:
    ConeTracer(const ConeGeometry& geometry, const ConeTraversalOptions& options, int max_depth,
               const std::atomic<bool>* stop)
        : m_scene(geometry.scene()),
          m_area_lights(geometry.area_lights()),
          m_traversal(geometry, options, stop),
          m_max_depth(max_depth),
          m_compositing(options.compositing),
          m_mask_every_cone(options.mask_every_cone),
          m_lights(options.highlight_mixture ? &geometry.highlight_lights() : nullptr) {}

    enum class Kind { Primary, Secondary };

    /// `leaving`: the surface a secondary cone leaves (ConeTraversal::trace); `compositing`: of
    /// its A-buffer, the render's where not given.
    Rgb radiance(const ConeRay& ray, float t_min, int depth, float weight, Kind kind,
                 ConeWork& work, std::uint32_t leaving = kAnySurface,
                 std::optional<Compositing> compositing = std::nullopt,
                 float leaving_side = 0.0f) const {
        const ConeComposite c =
            composite(ray, t_min, depth, weight, kind, work, leaving, compositing, leaving_side);
        return c.radiance + c.transmittance * m_scene.background;
    }

  private:
    /// What a cone's A-buffer composites to: the fragments' radiance, the share of the cone
    /// that nothing covers (where the background shows), and whether a fragment is of the
    /// surface the cone left.
    struct ConeComposite {
        Rgb radiance = Rgb::Zero();
        float transmittance = 1.0f;
        bool met_left_surface = false;
    };

    ConeComposite composite(const ConeRay& ray, float t_min, int depth, float weight, Kind kind,
                            ConeWork& work, std::uint32_t leaving,
                            std::optional<Compositing> compositing, float leaving_side) const {
        ABuffer<ConeSurface> buffer;
        buffer.set_compositing(compositing.value_or(m_compositing));
        const auto start = Clock::now();
        ConeTraversalStats& stats =
            kind == Kind::Primary ? work.stats.primary : work.stats.secondary;
        m_traversal.trace(ray, t_min, std::numeric_limits<float>::infinity(), buffer, stats,
                          leaving, kind == Kind::Primary || ray.cone.blurred, leaving_side);
        stats.abuffer += buffer.stats();
        const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
        (kind == Kind::Primary ? work.stats.primary_seconds : work.stats.secondary_seconds) +=
            seconds;
        const CompositeResult result = buffer.composite(
            [&](const ConeSurface& surface, const Fragment<ConeSurface>& f, float share) {
                return shade(surface, f, ray, depth, weight, share, work);
            });
        ConeComposite c;
        c.radiance = result.radiance;
        c.transmittance = result.transmittance;
        c.met_left_surface =
            leaving != kAnySurface &&
            std::any_of(buffer.fragments().begin(), buffer.fragments().end(),
                        [&](const Fragment<ConeSurface>& f) { return f.surface == leaving; });
        return c;
    }

    /// The radiance of a secondary cone inside the solid whose surface it left. Every ray
    /// inside a solid meets that solid's surface again, but a cone that starts wider than the
    /// solid (the pixel's footprint refracted through a bunny's curved surface, widened at
    /// every bounce inside it) also stands for rays that would start outside it, and those of
    /// its samples see past the solid: on the field, a third of the cones inside the glass
    /// bunnies met nothing over more than half of their cross-section and showed the sky, and
    /// the bunnies came out too bright by 0.026, 0.038, 0.058 (RGB; 0.014, 0.018, 0.023 with
    /// this). So
    ///  - a cone that met the solid gives the share nothing covered to what it met, the
    ///    coverage-normalised composite (as a point's attributes are normalised by its
    ///    weight), where an open surface's cone (a pane, which it never meets again) keeps
    ///    its background. Where the surface left is not known (a fragment of a group's coarse
    ///    points, or of surfaces merged into one), whatever the cone met is taken for it: a
    ///    pane seen that coarsely loses what lies beyond it where its cone is partly covered;
    ///  - a cone that met nothing at all is traced again narrow, nearer the rays along its
    ///    axis (kInsideRetraceScale), and shows the background only if that one meets nothing
    ///    either.
    Rgb inside_radiance(const ConeRay& ray, float t_min, int depth, float weight, ConeWork& work,
                        std::uint32_t leaving, Compositing compositing, float leaving_side) const {
        ConeComposite c = composite(ray, t_min, depth, weight, Kind::Secondary, work, leaving,
                                    compositing, leaving_side);
        if (c.transmittance >= 1.0f) {
            ++work.stats.inside_cones_retraced;
            ConeRay narrow = ray;
            narrow.cone.start_dev *= kInsideRetraceScale;
            narrow.cone.incr_dev *= kInsideRetraceScale;
            c = composite(narrow, t_min * kInsideRetraceScale, depth, weight, Kind::Secondary, work,
                          leaving, compositing, leaving_side);
        }
        if ((c.met_left_surface || leaving == kAnySurface) && c.transmittance > 0.0f &&
            c.transmittance < 1.0f) {
            ++work.stats.inside_cones_renormalised;
            return c.radiance / (1.0f - c.transmittance);
        }
        return c.radiance + c.transmittance * m_scene.background;
    }

    /// A fragment as the shader sees it: where the cone's axis meets it, the normal facing the
    /// cone, and the cone's footprint there.
    struct Hit {
        Vec3f position;
        Vec3f direction;  ///< The incoming cone's unit axis.
        Vec3f normal;     ///< Unit, facing against `direction`.
        Mat3f shape;      ///< The shape operator of that normal.
        bool entering = true;
        float half_interval = 0.0f;  ///< Half the fragment's depth interval.
        RayDifferential footprint;   ///< at_surface of the cone at the hit.
        /// The fragment's surface (Fragment::surface): what the cones leaving it leave.
        std::uint32_t surface = kAnySurface;
    };

    /// The footprint of `ray` at depth t as a ray differential on the surface with unit normal
    /// n: its columns projected along the ray onto the tangent plane (Igehy's transfer), and
    /// the directional differentials (for a blurred cone, of the convolved footprint).
    static RayDifferential at_surface(const ConeRay& ray, float t, const Vec3f& n) {
        const FootprintCone& cone = ray.cone;
        const FootprintCone::Local local = cone.local_at(t);
        const Mat32f position = cone.basis() * local.footprint;
        const Mat32f direction = cone.basis() * local.growth;
        RayDifferential rd;
        rd.dp_dx = position.col(0);
        rd.dp_dy = position.col(1);
        rd.dd_dx = direction.col(0);
        rd.dd_dy = direction.col(1);
        return rd.transfer(ray.direction, 0.0f, n);
    }

    static Hit hit_of(const ConeSurface& s, const Fragment<ConeSurface>& fragment,
                      const ConeRay& ray) {
        Hit hit;
        const Vec3f& d = ray.direction;
        const float t = fragment.depth();
        hit.position = ray.origin + t * d;
        hit.direction = d;
        const Vec3f n = s.normal.squaredNorm() > 0.0f ? s.normal : Vec3f(-d);
        hit.entering = n.dot(d) < 0.0f;
        hit.normal = hit.entering ? n : Vec3f(-n);
        hit.shape = hit.entering ? s.shape : Mat3f(-s.shape);
        hit.half_interval = 0.5f * (fragment.far - fragment.near);
        hit.surface = fragment.surface;
        hit.footprint = at_surface(ray, t, hit.normal);
        MRT_DCHECK(is_unit(hit.direction) && is_unit(hit.normal));
        return hit;
    }

    /// The material the fragment's Phong terms are evaluated with (phong_brdf and the area
    /// lights' highlight read only these two fields): its specular colour, and Toksvig's
    /// exponent for the spread of the normals across the footprint, widened further by the turn
    /// of its triangles' normals across it (ConeSurface::lobe_spread). Without it the bunnies
    /// of the paper's complex scene had highlights 2–4× the reference's (docs/cone-tracer.md).
    static Material footprint_material(const ConeSurface& s) {
        Material material;
        material.specular = s.specular;
        material.phong_exponent =
            widened_exponent(toksvig_exponent(s.phong_exponent, s.normal_length), s.lobe_spread);
        return material;
    }

    /// The fragment's radiance; `weight`: the cone's path weight, `share`: the fragment's part of
    /// the cone.
    Rgb shade(const ConeSurface& s, const Fragment<ConeSurface>& fragment, const ConeRay& ray,
              int depth, float weight, float share, ConeWork& work) const {
        MRT_DCHECK(std::isfinite(weight * share) && weight * share > 0.0f);
        const Hit hit = hit_of(s, fragment, ray);
        const Material material = footprint_material(s);
        const Rgb albedo = s.diffuse * local_share(s.reflectivity, s.transparency);
        // Emitting surfaces glow from their front: the side their mean normal faces.
        const Rgb emitted = s.normal.dot(hit.direction) < 0.0f ? s.emission : Rgb::Zero();
        const Rgb local = add_direct_light(m_scene.ambient * albedo + emitted, hit, material,
                                           albedo, s.highlights, weight, work);
        if (depth >= m_max_depth) {
            return local;
        }
        return add_secondary(local, s, hit, depth, weight * share, work);
    }

    /// The highlight of light `light` (HighlightLights' order) for a fragment whose mean normal's
    /// is `exact` and whose contributors' own average `mixture`: the mean normal's plus the
    /// mixture's difference from the same approximation at the mean normal
    /// (trace/cone/highlight_mixture.h). Exact where the contributors agree.
    float mixed_highlight(float exact, std::size_t light, const Hit& hit, const Material& material,
                          const std::array<float, kHighlightLights>& mixture) const {
        if (m_lights == nullptr || light >= m_lights->count()) {
            return exact;
        }
        const float mean = m_lights->of_light(light, hit.position, hit.normal, -hit.direction,
                                              material.phong_exponent);
        return std::max(0.0f, exact + mixture[light] - mean);
    }

    /// `result` plus what the lights deliver to the hit, each through its shadow cone.
    /// `highlights`: the fragment's mixture of its contributors' highlights (ConeSurface);
    /// `weight`: the path weight of the cone the fragment is in. A light whose unshadowed
    /// radiance, times that weight, is below kMinimumWeight (as a branch of the ray tree not worth
    /// tracing) adds nothing and costs no shadow cone: the mixture's highlights gave many
    /// fragments facing away from a light a trace of one. The cone's weight, not the fragment's
    /// share of it: the shares of a cone's fragments add up to at most 1, so what the cone loses
    /// to the bound stays below it, where a bound on each share would let sixteen fragments
    /// each lose nearly as much.
    Rgb add_direct_light(Rgb result, const Hit& hit, const Material& material, const Rgb& albedo,
                         const std::array<float, kHighlightLights>& highlights, float weight,
                         ConeWork& work) const {
        const Vec3f& p = hit.position;
        const Vec3f& ns = hit.normal;
        const Vec3f wo = -hit.direction;
        const bool specular = (material.specular > 0.0f).any();
        std::size_t light_index = 0;
        for (const PointLight& light : m_scene.point_lights) {
            const std::size_t index = light_index++;
            const LightSample sample = sample_point_light(light, p);
            const float cosine = ns.dot(sample.wi);
            if (cosine <= 0.0f || (sample.irradiance <= 0.0f).all()) {
                continue;
            }
            Rgb delivered =
                sample.irradiance * cosine * phong_brdf(material, albedo, ns, sample.wi, wo);
            if (specular) {
                // phong_brdf's lobe times the cosine, moved to the mixture's.
                const float exact = cosine * phong_lobe(material.phong_exponent, ns, sample.wi, wo);
                delivered += sample.irradiance * material.specular *
                             (mixed_highlight(exact, index, hit, material, highlights) - exact);
            }
            if (!worth_tracing(weight, delivered.maxCoeff())) {
                continue;
            }
            ++work.rays.shadow;
            const float visible = visibility(hit, sample, nullptr, cosine, work).transmittance;
            if (visible > 0.0f) {
                result += visible * delivered;
            }
        }
        for (const EllipticalAreaLight& light : m_area_lights) {
            const std::size_t index = light_index++;
            // The light's whole extent gives the unoccluded irradiance and the highlight
            // (trace/render/area_light.h); the shadow cone towards its centre, widened by its
            // ellipse, gives the share of it that is visible.
            const LightSample sample = sample_area_light_centre(light, p);
            AreaLightTerms terms = area_light_terms(light, p, ns, wo, material);
            if (specular) {
                terms.highlight =
                    mixed_highlight(terms.highlight, index, hit, material, highlights);
            }
            if (!worth_tracing(weight, terms.reflected(light, material, albedo).maxCoeff())) {
                continue;
            }
            ++work.rays.shadow;
            // A light straddling the tangent plane still gets its shadow cone towards the
            // centre, started as a grazing cone would be.
            const float cosine = std::max(ns.dot(sample.wi), kGrazingLightCosine);
            FootprintCone cone;
            const CompositeResult seen = visibility(hit, sample, &light, cosine, work, &cone);
            if (m_compositing == Compositing::Mask) {
                // The penumbra's visible part of the light weighed by what it delivers
                // (trace/cone/light_share.h); the highlight by the samples' count.
                result += terms.reflected(light, material, albedo,
                                          unblocked_light_share(light, p, ns, cone, seen.covered),
                                          1.0f - mask_coverage(seen.covered));
            } else if (seen.transmittance > 0.0f) {
                result += seen.transmittance * terms.reflected(light, material, albedo);
            }
        }
        return result;
    }

    /// The fraction of the footprint's Gaussian that refracts at the hit, where a ray refracts
    /// when k = 1 − η²(1 − cos²θ) > 0. To first order in the pixel offset, dk = 2η²·cos θ·
    /// d(cos θ) with d(cos θ) = −(dD·N + D·dN); over the footprint's Gaussian exp(−|x|²) the
    /// share with k > 0 is ½·erfc(−k / |∇k|): 0 or 1 but where the footprint straddles the
    /// critical angle.
    static float refracted_fraction(const Hit& hit, const Vec3f& dn_dx, const Vec3f& dn_dy,
                                    float eta, float cos_i) {
        const Vec3f& d = hit.direction;
        const Vec3f& ns = hit.normal;
        const float k = 1.0f - eta * eta * (1.0f - cos_i * cos_i);
        const float dk_dx =
            -2.0f * eta * eta * cos_i * (hit.footprint.dd_dx.dot(ns) + d.dot(dn_dx));
        const float dk_dy =
            -2.0f * eta * eta * cos_i * (hit.footprint.dd_dy.dot(ns) + d.dot(dn_dy));
        const float spread = std::hypot(dk_dx, dk_dy);
        if (spread > 0.0f && std::isfinite(spread)) {
            return 0.5f * std::erfc(-k / spread);
        }
        return k > 0.0f ? 1.0f : 0.0f;
    }

    /// `local` plus the refracted and reflected cones, weighted as every tracer's ray tree
    /// (trace/render/scattering.h); the transmitted share is split between them by the fraction
    /// of the footprint that refracts.
    Rgb add_secondary(const Rgb& local, const ConeSurface& s, const Hit& hit, int depth,
                      float weight, ConeWork& work) const {
        const Vec3f& d = hit.direction;
        const Vec3f& ns = hit.normal;
        const Vec3f dn_dx = hit.shape * hit.footprint.dp_dx;
        const Vec3f dn_dy = hit.shape * hit.footprint.dp_dy;
        const float eta = hit.entering ? 1.0f / std::max(s.ior, kMinimumIor) : s.ior;
        const float cos_i = std::min(1.0f, -d.dot(ns));
        float refracted = 0.0f;
        if (s.transparency > 0.0f) {
            refracted = refracted_fraction(hit, dn_dx, dn_dy, eta, cos_i);
            if (refracted > kStraddleShare && refracted < 1.0f - kStraddleShare) {
                ++work.stats.straddled_critical_angle;
            }
        }
        const BranchWeights branches = branch_weights(s.reflectivity, s.transparency, refracted);
        const auto refract_branch = [&](float branch_weight) {
            // Past the critical angle at the centre the refracted part leaves along the
            // surface: the critical direction.
            const Vec3f direction = fold_to_side(
                refract(d, ns, eta).value_or(Vec3f((eta * d + eta * cos_i * ns).normalized())), ns,
                Side::Below);
            const RayDifferential rd = hit.footprint.refract(d, ns, dn_dx, dn_dy, eta);
            // Through the surface from outside: into the solid.
            return secondary(hit, direction, rd, s.roughness, depth, branch_weight, work,
                             hit.entering);
        };
        const auto reflect_branch = [&](float branch_weight) {
            const Vec3f direction = fold_to_side(reflect(d, ns), ns, Side::Above);
            const RayDifferential rd = hit.footprint.reflect(d, ns, dn_dx, dn_dy);
            // Mirrored back from the inside of a transparent surface: still in the solid.
            return secondary(hit, direction, rd, s.roughness, depth, branch_weight, work,
                             !hit.entering && s.transparency > 0.0f);
        };
        return add_branches(local, weight, branches, refract_branch, reflect_branch);
    }

    /// The A-buffer's compositing for a secondary cone of depth `depth`. Masks cost most in
    /// the cones that travel inside solids and in those spread so wide that their spread had to
    /// be bounded: a cone inside a glass bunny meets the bunny's own surface all around it, at
    /// many depths, and masks keep those apart as fragments that each send on a reflected and
    /// a refracted cone, so the tree grows with every interaction where alpha's first fragment
    /// saturates. On the field those cones made masks cost 1.55× alpha, and compositing them by
    /// alpha changed every scene's error by at most 1 % (most fell). The first cone into a
    /// solid keeps masks: what is seen through a glass's wall (the desk's) is sharp, and alpha
    /// there cost the desk 10 % of display RMSE.
    Compositing secondary_compositing(int depth, bool inside, bool spread_bounded) const {
        if (m_compositing == Compositing::Mask && !m_mask_every_cone &&
            (spread_bounded || (inside && depth >= 2))) {
            return Compositing::Alpha;
        }
        return m_compositing;
    }

    /// `inside`: the cone travels inside the solid whose surface it leaves.
    Rgb secondary(const Hit& hit, const Vec3f& direction, const RayDifferential& rd,
                  float roughness, int depth, float weight, ConeWork& work, bool inside) const {
        ++work.rays.secondary;
        ConeRay ray;
        ray.origin = hit.position;
        ray.direction = direction;
        ray.cone = FootprintCone::from_differential(direction, rd);
        const float growth = largest_singular_value(ray.cone.incr_dev);
        const bool spread_bounded = growth > kMaximumSecondaryGrowth;
        if (spread_bounded) {
            ray.cone.incr_dev *= kMaximumSecondaryGrowth / growth;
        }
        if (roughness > 0.0f) {
            // The Gaussian spread of the stochastic tracers' glossy directions
            // (gaussian_spread_direction, σ = roughness per unit distance) is exp(−|x|²/b²)
            // with b = √2·σ·t: a radial increment.
            ray.cone.add_blur(Mat2f::Zero(), std::sqrt(2.0f) * roughness * Mat2f::Identity());
        }
        // A fragment's depth interval keeps a cone off what stands next to the surface it
        // leaves. A fragment of no one surface (a group's coarse points, which stand for many
        // objects, or surfaces merged by alpha or by a full buffer) spans several surfaces, and
        // its interval says nothing about where the one the cone leaves lies; the traversal
        // already takes every primitive near the apex for that surface there. Inside the field's
        // glass bunnies such intervals reached hundreds of units and started cones beyond the
        // bunny: display RMSE at 640×480 0.0505 → 0.0497 without them.
        const float t_min = start_clearance(ray.cone.start_dev, direction.dot(hit.normal),
                                            hit.surface == kAnySurface ? 0.0f : hit.half_interval);
        // Which side of where it starts the cone leaves on, against the fragment's own normal
        // (outward on a closed surface): hit.normal faces the incoming cone.
        const float outward_along = (hit.entering ? 1.0f : -1.0f) * direction.dot(hit.normal);
        const float leaving_side = outward_along > 0.0f ? 1.0f : -1.0f;
        const Compositing compositing = secondary_compositing(depth + 1, inside, spread_bounded);
        if (inside) {
            return inside_radiance(ray, t_min, depth + 1, weight, work, hit.surface, compositing,
                                   leaving_side);
        }
        return radiance(ray, t_min, depth + 1, weight, Kind::Secondary, work, hit.surface,
                        compositing, leaving_side);
    }

    /// What the shadow cone from the fragment `hit` to the light lets through (and the cone,
    /// where asked: the frame its masks' samples are in).
    CompositeResult visibility(const Hit& hit, const LightSample& light,
                               const EllipticalAreaLight* area, float cosine, ConeWork& work,
                               FootprintCone* used = nullptr) const {
        const RayDifferential& at_hit = hit.footprint;
        ConeRay ray;
        ray.origin = hit.position;
        ray.direction = light.wi;
        FootprintCone& cone = ray.cone;
        orthonormal_basis(light.wi, cone.u, cone.v);
        // The hit's footprint, shrinking to nothing at the light.
        cone.start_dev = cone.project(at_hit.dp_dx, at_hit.dp_dy);
        cone.incr_dev = -cone.start_dev / light.distance;
        if (area != nullptr) {
            // The light's ellipse, from nothing at the hit; a uniform disc of radius a has
            // the variance of the Gaussian exp(−|x|²/(a/√2)²).
            const Mat2f ellipse = cone.project(area->semi_axis_u, area->semi_axis_v);
            cone.add_blur(Mat2f::Zero(), ellipse / (std::sqrt(2.0f) * light.distance));
        }
        const float t_min =
            std::min(start_clearance(cone.start_dev, cosine, 0.0f, kShadowSelfIntersectionFactor),
                     0.5f * light.distance);
        ABuffer<ConeOpacity> buffer;
        // Toward an elliptical light each of the masks' samples is a ray to one point of it.
        buffer.set_compositing(
            m_compositing, area != nullptr ? SamplePattern::LightDisc : SamplePattern::Gaussian);
        const auto start = Clock::now();
        m_traversal.trace(ray, t_min, light.distance * kShadowEndFraction, buffer,
                          work.stats.shadow, hit.surface);
        work.stats.shadow.abuffer += buffer.stats();
        work.stats.shadow_seconds += std::chrono::duration<double>(Clock::now() - start).count();
        if (used != nullptr) {
            *used = cone;
        }
        return buffer.composite(
            [](const ConeOpacity&, const Fragment<ConeOpacity>&) { return Rgb::Zero(); });
    }

    const Scene& m_scene;
    /// The scene's ellipses and its mesh lights' equivalent ones (trace/render/mesh_light.h).
    const std::vector<EllipticalAreaLight>& m_area_lights;
    ConeTraversal m_traversal;
    int m_max_depth;
    Compositing m_compositing;
    bool m_mask_every_cone;
    /// For the mean normal's side of the highlight mixture; null where it is off.
    const HighlightLights* m_lights;
};

/// Sets a flag after a delay, unless cancelled first: the time guard, which has to stop
/// traversals that are already running (one pixel of classic cone tracing can take minutes).
class Watchdog {
  public:
    Watchdog(double seconds, std::atomic<bool>& flag) : m_flag(flag) {
        if (seconds > 0.0) {
            m_thread = std::thread([this, seconds] {
                std::unique_lock lock(m_mutex);
                if (!m_cancel.wait_for(lock, std::chrono::duration<double>(seconds),
                                       [this] { return m_done; })) {
                    m_flag.store(true, std::memory_order_relaxed);
                }
            });
        }
    }
    ~Watchdog() {
        {
            const std::lock_guard lock(m_mutex);
            m_done = true;
        }
        m_cancel.notify_all();
        if (m_thread.joinable()) {
            m_thread.join();
        }
    }
    Watchdog(const Watchdog&) = delete;
    Watchdog& operator=(const Watchdog&) = delete;

  private:
    std::atomic<bool>& m_flag;
    std::mutex m_mutex;
    std::condition_variable m_cancel;
    bool m_done = false;
    std::thread m_thread;
};

}  // namespace

std::ostream& operator<<(std::ostream& os, const ConeRenderStats& s) {
    return print_fields(os, "ConeRenderStats", s);
}

float cone_pixel_scale(const PixelFilter& filter) {
    if (filter.kind == PixelFilter::Kind::Gaussian) {
        return std::sqrt(2.0f) * filter.sigma;
    }
    // A box of width 2r has variance r²/3 per axis; exp(−x²/s²) has s²/2.
    return std::sqrt(2.0f / 3.0f) * filter.radius;
}

ConeRenderOutput render_cone(const ConeGeometry& geometry, const RenderOptions& options,
                             const ConeOptions& cone_options) {
    const Scene& scene = geometry.scene();
    const CameraRays camera(scene.camera, options.width, options.height);
    const int max_depth = options.max_depth >= 0 ? options.max_depth : scene.max_depth;
    std::atomic<bool> stop{false};
    const float scale = cone_pixel_scale(options.filter);
    ConeTraversalOptions traversal = cone_options.traversal;
    traversal.texture_footprint_scale = 1.0f / scale;
    const ConeTracer tracer(geometry, traversal, max_depth, &stop);
    const float aperture = scene.camera.aperture_radius;
    const auto primary = [&](float rx, float ry, float width) {
        ConeRay ray;
        if (aperture > 0.0f) {
            const Ray centre = camera.lens_ray(rx, ry, 0.5f, 0.5f);
            ray.origin = centre.origin;
            ray.direction = centre.direction.normalized();
            ray.cone = FootprintCone::from_differential(
                ray.direction, camera.lens_differential(rx, ry, 0.5f, 0.5f, width));
        } else {
            const Ray centre = camera.pinhole_ray(rx, ry);
            ray.origin = centre.origin;
            ray.direction = centre.direction.normalized();
            ray.cone = FootprintCone::from_differential(ray.direction,
                                                        camera.pinhole_differential(rx, ry, width));
        }
        // Never narrower than float positions resolve: a cone of 1e-10 rad (fov 1e-6°) weighed
        // triangles by offsets that were rounding noise, and lost most of them (sky through the
        // floor).
        if (FootprintCone::ellipse_of(ray.cone.incr_dev).minor < kMinimumSpread * kMinimumSpread) {
            ray.cone.incr_dev = FootprintCone::widened(ray.cone.incr_dev, kMinimumSpread);
        }
        if (aperture > 0.0f) {
            // The aperture's cone: the lens disc at the lens, nothing in focus.
            const float focus =
                scene.camera.focal_distance /
                std::max(ray.direction.dot(camera.forward()), kMinimumForwardCosine);
            const float b = aperture / std::sqrt(2.0f);
            ray.cone.add_blur(b * Mat2f::Identity(), (-b / focus) * Mat2f::Identity());
        }
        return ray;
    };
    const PrimarySplit split = primary_split(camera, options.filter, scale);
    MRT_CHECK(split.cells >= 1 && split.cells <= kMaximumPrimaryCells && split.cell > 0.0f &&
              (split.cells == 1 || !split.cones.empty()));
    const auto trace_pixel = [&](float rx, float ry, ConeWork& local, RayCounters& counters) {
        if (split.cells == 1) {
            ++counters.primary;
            return tracer.radiance(primary(rx, ry, scale), 0.0f, 0, 1.0f, ConeTracer::Kind::Primary,
                                   local);
        }
        // A pixel wider than one cone can stand for: sub-cones on a grid over the filter's
        // support, weighed by the filter, each the box of its cell. Each is the pixel's value
        // where it looks, so its ray tree is pruned as a whole pixel's (path weight 1): with
        // their shares as path weights a 1×1 frame's 4096 cones lost every light to the bound.
        Rgb radiance = Rgb::Zero();
        for (const SubCone& cone : split.cones) {
            ++counters.primary;
            radiance +=
                cone.share * tracer.radiance(primary(rx + cone.dx, ry + cone.dy, split.scale), 0.0f,
                                             0, 1.0f, ConeTracer::Kind::Primary, local);
        }
        return radiance;
    };
    // Refinement's 2 × 2 cones: half the width, at ±(√3/2)·σ from the centre on each axis, so
    // that the four together have the pixel cone's variance σ² (σ² = scale²/2 for exp(−x²/s²);
    // for the box of a pixel the offsets are ±1/4 and the cones are the boxes of the quarters).
    // Where the four still differ by the contrast, each that differs from a neighbour is split
    // the same way, down to cone_options.refine_levels.
    const float contrast = cone_options.refine_contrast;
    const auto trace_refined = [&](float rx, float ry, ConeWork& local, RayCounters& counters) {
        // Each cone's ray tree pruned as a whole pixel's, as the grid's (trace_pixel): they are
        // the cones of a render at twice (four times) the resolution.
        const auto quad = [&](const auto& self, float cx, float cy, float width, int level) -> Rgb {
            const float offset = std::sqrt(3.0f / 8.0f) * width;
            const float half = 0.5f * width;
            std::array<Rgb, 4> values;  // (−,−), (+,−), (−,+), (+,+)
            for (int k = 0; k < 4; ++k) {
                ++counters.primary;
                values[k] = tracer.radiance(primary(cx + ((k & 1) != 0 ? offset : -offset),
                                                    cy + ((k & 2) != 0 ? offset : -offset), half),
                                            0.0f, 0, 1.0f, ConeTracer::Kind::Primary, local);
            }
            if (level < cone_options.refine_levels) {
                const auto differs = [&](int a, int b) {
                    return ((values[a] - values[b]).abs() > contrast).any();
                };
                // Each quarter's neighbours across the two edges it shares with the others.
                std::array<bool, 4> divide{};
                for (int k = 0; k < 4; ++k) {
                    divide[k] = differs(k, k ^ 1) || differs(k, k ^ 2);
                }
                for (int k = 0; k < 4; ++k) {
                    if (divide[k]) {
                        values[k] = self(self, cx + ((k & 1) != 0 ? offset : -offset),
                                         cy + ((k & 2) != 0 ? offset : -offset), half, level + 1);
                    }
                }
            }
            return Rgb(0.25f * (values[0] + values[1] + values[2] + values[3]));
        };
        return quad(quad, rx, ry, scale, 1);
    };
    // Pixels already traced as a grid of cones are not refined further.
    const bool refine = cone_options.refine_contrast > 0.0f && split.cells == 1;
    // The cone is the pixel's filter: each pixel's one sample is its value.
    Film film(options.width, options.height, PixelFilter::box(), options.crop);
    const PixelWindow& window = film.window();
    // Refinement compares each pixel of the window with its neighbours, one pixel beyond it.
    const PixelWindow around{std::max(0, window.x0 - 1), std::max(0, window.y0 - 1),
                             std::min(options.width, window.x1 + 1),
                             std::min(options.height, window.y1 + 1)};
    PixelValues first(refine ? around : PixelWindow{});
    tbb::enumerable_thread_specific<ConeWork> work;
    const auto start = Clock::now();
    ConeRenderOutput out;
    {
        const Watchdog watchdog(cone_options.time_budget, stop);
        const std::string label(
            to_string(cone_options.traversal.points ? Method::Cone : Method::ConeClassic));
        out.render.rays = film.add_pass(
            options.threads, label, options.quiet,
            [&](int x, int y, FilmTile& tile, RayCounters& counters) {
                ConeWork& local = work.local();
                ++local.stats.pixels;
                if (stop.load(std::memory_order_relaxed)) {
                    return;
                }
                const float rx = static_cast<float>(x) + 0.5f;
                const float ry = static_cast<float>(y) + 0.5f;
                const Rgb radiance = trace_pixel(rx, ry, local, counters);
                if (stop.load(std::memory_order_relaxed)) {
                    return;  // cut short: leave the pixel empty rather than wrong
                }
                ++local.stats.pixels_done;
                if (refine) {
                    if (first.contains(x, y)) {
                        first.set(x, y, radiance);  // each pixel by one tile: no race
                    }
                } else {
                    tile.add_sample(rx, ry, radiance);
                }
            },
            refine ? 1 : 0);
        if (refine) {
            const std::vector<std::uint8_t> high =
                high_contrast_pixels(first, window, cone_options.refine_contrast);
            // Pass 1 splatted nothing when refining: this pass writes every pixel.
            const RayCounters refined = film.add_pass(
                options.threads, label + " refinement", options.quiet,
                [&](int x, int y, FilmTile& tile, RayCounters& counters) {
                    if (!window.contains(x, y) || !first.known(x, y)) {
                        return;
                    }
                    const float rx = static_cast<float>(x) + 0.5f;
                    const float ry = static_cast<float>(y) + 0.5f;
                    Rgb radiance = first.at(x, y);
                    if (high[window.offset(x, y)] != 0 && !stop.load(std::memory_order_relaxed)) {
                        ConeWork& local = work.local();
                        const Rgb finer = trace_refined(rx, ry, local, counters);
                        // Stopped inside: the pixel keeps its one cone's value.
                        if (!stop.load(std::memory_order_relaxed)) {
                            radiance = finer;
                            ++local.stats.refined_pixels;
                        }
                    }
                    tile.add_sample(rx, ry, radiance);
                });
            out.render.rays += refined;
        }
    }
    out.render.image = film.image();
    out.render.samples = 0;
    for (const ConeWork& w : work) {
        out.stats += w.stats;
        out.render.rays.secondary += w.rays.secondary;
        out.render.rays.shadow += w.rays.shadow;
    }
    out.stats.stopped = stop.load();
    out.render.samples = out.stats.pixels_done;
    out.render.spp = 1;
    out.render.render_seconds = std::chrono::duration<double>(Clock::now() - start).count();
    out.render.last_pass_seconds = out.render.render_seconds;
    return out;
}

}  // namespace mrt
