#pragma once
// ellipse_mask's 64 tests of a quadratic form as a Highway kernel
// (trace/cone/coverage_mask_simd.cpp), compiled once per instruction set and dispatched at run time
// as the block kernels are (trace/cone/cone_block_simd.h): a point's mask is made for every point a
// masked cone weighs, the largest cost the masks add to a cone (docs/cone-tracer.md, "Coverage
// masks").

#include "trace/cone/coverage_mask.h"

namespace mrt {

/// The samples y with xx·dx² + 2·xy·dx·dy + yy·dy² ≤ 1, (dx, dy) = y − (cx, cy), evaluated as
/// ellipse_mask_scalar does, bit for bit.
CoverageMask samples_in_ellipse(const CoverageSamples& samples, float cx, float cy, float xx,
                                float xy, float yy);

}  // namespace mrt
