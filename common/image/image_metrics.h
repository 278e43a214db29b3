#pragma once
// Error between an image and a reference: the numbers every comparison reports.

#include "common/image/image.h"

namespace mrt {

/// Root-mean-square error over all pixels and the three channels (linear values).
double rmse(const Image& image, const Image& reference);

/// The same over values clamped to [0, 1] first, as a display shows them: a few highlights far
/// above 1 cannot outweigh the rest of the image.
double display_rmse(const Image& image, const Image& reference);

/// Peak signal-to-noise ratio in dB with peak value `peak` (default 1 for [0,1] linear images):
/// 20·log10(peak / rmse); +inf for identical images.
double psnr(const Image& image, const Image& reference, double peak = 1.0);

/// Mean structural similarity (Wang et al. 2004) on luminance, with the paper's constants
/// (K1 = 0.01, K2 = 0.03, dynamic range L = 1, 11×11 Gaussian window σ = 1.5, computed where
/// the window fits inside the image; images smaller than the window use the whole image).
/// Luminance is clamped to [0, 1] first.
double ssim(const Image& image, const Image& reference);

/// Per-pixel error image: |image − reference| averaged over channels, shown in false colour
/// (black → blue → green → yellow → red → white as the error goes from 0 to `max_error`).
Image error_image(const Image& image, const Image& reference, float max_error);

}  // namespace mrt
