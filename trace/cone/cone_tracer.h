#pragma once
// The multi-resolution cone tracer (Wand & Straßer §4–6; methods `cone` and `cone-classic`):
// one anisotropic Gaussian ray cone per pixel through the point hierarchy of a .mrh file
// (trace/cone/cone_traversal.h), composited through the per-ray A-buffer (trace/cone/abuffer.h),
// every fragment shaded with the same Phong model as the baselines (trace/render/shading.h):
//
// - Primary cones: zero start, the pixel's increment (the pinhole's ray differential), scaled
//   so that the cone's Gaussian has the second moment of the reconstruction filter the
//   reference is rendered with (box: 1/√6 of a pixel, Gaussian σ: σ·√2). Depth of field: the
//   lens aperture's own cone, zero in the focal plane and growing linearly on both sides,
//   convolved with the pixel cone, so the footprint never falls below the pixel's (§4.2).
// - Shadow cones to every light, the hit's footprint shrinking to the light; for elliptical
//   area lights convolved with the cone that grows from the hit to the light's ellipse (§4.2):
//   soft shadows as the transmittance of one cone, no samples.
// - Reflected and refracted cones from the footprint projected onto the tangent plane and the
//   surface's shape operator (the surfel's fitted normal gradient, or the normal-interpolated
//   triangle's), with Igehy's exact derivatives (common/footprint/footprint.h). Roughness widens
//   the cone radially (blurry reflections). Where the footprint straddles the critical angle the
//   transmitted share is split between a refracted and a totally reflected cone by the
//   fraction of the footprint's Gaussian that refracts (the paper decides per cone by its
//   centre; it names the blend as future work).
//
// Self-intersection: a cone leaving a surface starts where its own clip ellipse has cleared
// the surface's tangent plane (the paper's "threshold ... based on the angle and the diameter
// of the outgoing ray cone").
//
// Deterministic: nothing is random, every pixel is computed independently.

#include "common/hierarchy/hierarchy_file.h"
#include "common/scene/scene.h"
#include "common/texture/texture.h"
#include "trace/cone/cone_traversal.h"
#include "trace/render/render.h"

#include <atomic>
#include <cstdint>
#include <iosfwd>
#include <string>

namespace mrt {

class CameraRays;

struct ConeOptions {
    ConeTraversalOptions traversal;
    /// Seconds after which the render stops cleanly with the pixels done so far (0: no limit):
    /// the guard of classic cone tracing, which on a detailed scene runs for hours.
    double time_budget = 0.0;
    /// Adaptive refinement (0: off): a pixel traced as one cone whose value differs from an edge
    /// neighbour's by more than this in any channel (trace/render/pixel_contrast.h) is traced
    /// again as 2 × 2 cones of half the width, which together have its filter's variance.
    float refine_contrast = 0.0f;
    /// Refinement splits a pixel's cone at most this many times (2 × 2 per level); from the second
    /// level on, the quarters that differ from a neighbouring quarter by refine_contrast.
    int refine_levels = 1;
};

/// Where the render's time went, and what its traversals did.
struct ConeRenderStats {
    ConeTraversalStats primary;
    ConeTraversalStats secondary;  ///< Reflected and refracted cones.
    ConeTraversalStats shadow;
    /// Seconds of worker time, summed over threads: traversal of each kind; the rest of the
    /// render (cone setup, shading, compositing) is `render_seconds · threads − these`.
    double primary_seconds = 0.0;
    double secondary_seconds = 0.0;
    double shadow_seconds = 0.0;
    std::uint64_t straddled_critical_angle = 0;  ///< Refractions split with total reflection.
    /// Cones inside a solid that met nothing and were traced again narrow (kInsideRetraceScale).
    std::uint64_t inside_cones_retraced = 0;
    /// Cones inside a solid that met it over part of their cross-section and gave it the rest.
    std::uint64_t inside_cones_renormalised = 0;
    std::uint64_t pixels_done = 0;
    std::uint64_t pixels = 0;
    std::uint64_t refined_pixels = 0;  ///< Traced again as 2 × 2 cones (refine_contrast).
    bool stopped = false;              ///< The time budget ran out before every pixel was done.

    /// Named as --stats writes them.
    static constexpr auto fields = std::tuple{
        Field{"primary", &ConeRenderStats::primary},
        Field{"secondary", &ConeRenderStats::secondary},
        Field{"shadow", &ConeRenderStats::shadow},
        Field{"primary_traversal_thread_seconds", &ConeRenderStats::primary_seconds},
        Field{"secondary_traversal_thread_seconds", &ConeRenderStats::secondary_seconds},
        Field{"shadow_traversal_thread_seconds", &ConeRenderStats::shadow_seconds},
        Field{"straddled_critical_angle", &ConeRenderStats::straddled_critical_angle},
        Field{"inside_cones_retraced", &ConeRenderStats::inside_cones_retraced},
        Field{"inside_cones_renormalised", &ConeRenderStats::inside_cones_renormalised},
        Field{"pixels_done", &ConeRenderStats::pixels_done},
        Field{"pixels", &ConeRenderStats::pixels},
        Field{"refined_pixels", &ConeRenderStats::refined_pixels},
        Field{"stopped", &ConeRenderStats::stopped},
    };
    ConeRenderStats& operator+=(const ConeRenderStats& o) { return add_fields(*this, o); }
};

std::ostream& operator<<(std::ostream& os, const ConeRenderStats& s);

struct ConeRenderOutput {
    RenderOutput render;
    ConeRenderStats stats;
};

/// Pixel units of the primary cone's increment for the reconstruction filter: its Gaussian
/// exp(−|x|²/s²) has the filter's variance (box of a pixel: 1/12 per axis; Gaussian: σ²).
float cone_pixel_scale(const PixelFilter& filter);

/// Renders the scene's camera with the cone tracer over `geometry` (the hierarchy file and the
/// scene it stands for). options.width/height/threads/max_depth/quiet are read; options.filter
/// sets the cone's width (cone_pixel_scale); one cone per pixel, at its centre, then 2 × 2 in the
/// pixels cone_options.refine_contrast picks. The progress bar
/// is labelled with the method cone_options.traversal.points makes it (cone or cone-classic).
ConeRenderOutput render_cone(const ConeGeometry& geometry, const RenderOptions& options,
                             const ConeOptions& cone_options);

}  // namespace mrt
