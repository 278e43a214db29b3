#pragma once
// The share of an elliptical light's irradiance that a shadow cone's coverage mask lets
// through. Toward an elliptical light each sample of a shadow cone's mask is a ray to one
// point of the light (SamplePattern::LightDisc), a uniform share of its area; the samples the
// occluders cover block those points. Counting the free samples gives the visible share of the
// light's area, but a penumbra's visible part is not an average part of the light: near a
// large light the part seen past an occluder can lie overhead (steep, close, bright) or at the
// horizon (grazing, far, dim). Each sample is weighed instead as the distributed tracer weighs
// a light sample, cos θ at the receiver · cos θ' at the light / r², so that the share is of the
// irradiance (docs/cone-tracer.md, "Shadow cones' samples on the light").

#include "common/footprint/footprint.h"
#include "common/math/math.h"
#include "common/scene/scene.h"
#include "trace/cone/coverage_mask.h"

#include <optional>

namespace mrt {

/// The share of `light`'s irradiance at p (unit normal n) that the samples not in `covered`
/// deliver, for a shadow cone of frame (cone.u, cone.v) toward the light's centre whose
/// footprint at the light is the light's ellipse, as ConeTracer::visibility builds it. 1 for no
/// sample covered, 0 for all; the count's share, 1 − mask_coverage(covered), where the light is
/// seen edge-on or gives p nothing. (The highlight keeps the count's share: 64 samples do not
/// resolve a sharp lobe, and weighing them by it made the two-spheres' glass worse.)
float unblocked_light_share(const EllipticalAreaLight& light, const Vec3f& p, const Vec3f& n,
                            const FootprintCone& cone, CoverageMask covered);

/// The linear map from a LightDisc sample's position (coverage_samples) to where its ray meets
/// the light, in the unit disc of the light's semi-axes (centre + x·semi_axis_u +
/// y·semi_axis_v), for such a cone; nullopt where the light is seen edge-on.
std::optional<Mat2f> light_disc_map(const EllipticalAreaLight& light, const FootprintCone& cone);

}  // namespace mrt
