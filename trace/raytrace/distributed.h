#pragma once
// The adaptive distributed ray tracer (Cook, Porter & Carpenter 1984), the stochastic baseline
// of Wand & Straßer §6 and the ground truth the cone tracer approximates. Every effect is
// sampled: the pixel area (anti-aliasing), the lens (thin-lens depth of field), each
// elliptical area light (a uniform point per sample: soft shadows) and the Gaussian spread of
// rough reflection and refraction (glossy), over the same ray tree as the Whitted tracer.
//
// Sampling schedule:
// - Pass 1 shoots spp_initial jittered samples in every pixel.
// - The variance of the sample luminances pooled over each pixel's 5×5 neighbourhood estimates
//   how noisy the pixel is (the neighbourhood also catches features the few samples of one
//   pixel missed).
// - Pass 2 gives each pixel a new stratified batch (a sub-pixel grid, N-rooks when not square)
//   so that its standard error var/n would reach target_error, at most spp_max in all.
// - With a time budget, further passes follow while time remains: each distributes about one
//   pass-1 worth of samples over the pixels in proportion to the error each sample removes
//   there (var/n²), at most doubling a pixel per pass, sized to fit the time left.
// - A reference renders spp samples as 8 independent stratified batches; the spread of the
//   batch images gives its standard error (the stratification makes the usual per-sample
//   variance formula overestimate it).
// - Fixed sampling renders one stratified batch of spp samples in every pixel.
//
// Images are deterministic for a seed and any thread count, except in time-budget mode where
// the number of passes depends on the machine's speed.

#include "common/scene/scene.h"
#include "common/texture/texture.h"
#include "trace/bvh/scene_bvh.h"
#include "trace/render/render.h"

#include <cstdint>

namespace mrt {

/// How the distributed tracer chooses its samples (see above).
enum class DistributedSampling : std::uint8_t {
    Adaptive,   ///< Pass 1, then pass 2 or time-budget passes.
    Fixed,      ///< One stratified batch of `spp` samples in every pixel.
    Reference,  ///< Ground truth: `spp` samples in independent batches, with a standard error.
};

/// What the distributed tracer reads beyond RenderOptions.
struct DistributedOptions {
    DistributedSampling sampling = DistributedSampling::Adaptive;
    int spp = 1;                  ///< Fixed and Reference: samples per pixel.
    int spp_initial = 2;          ///< Adaptive pass 1: jittered samples in every pixel.
    int spp_max = 16;             ///< Adaptive pass 2 and later: at most this many in any pixel.
    float target_error = 0.005f;  ///< Adaptive pass 2 aims at this per-pixel standard error.
    double time_budget = 0.0;     ///< Adaptive, seconds; > 0: refine in passes until spent.
};

/// Renders the scene's camera with the distributed ray tracer (see above for the modes),
/// textures from `textures` (built for options.texture_filter).
RenderOutput render_distributed(const Scene& scene, const SceneBvh& bvh,
                                const TextureSampler& textures, const RenderOptions& options,
                                const DistributedOptions& distributed = {});

/// The same, preparing the textures itself.
RenderOutput render_distributed(const Scene& scene, const SceneBvh& bvh,
                                const RenderOptions& options,
                                const DistributedOptions& distributed = {});

}  // namespace mrt
