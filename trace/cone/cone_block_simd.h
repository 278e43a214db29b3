#pragma once
// The block tests of trace/cone/cone_bound_block.h (spheres_near_axis, voxels_within_clip,
// children_near_cone) are Highway kernels (trace/cone/cone_block_simd.cpp), compiled once per
// instruction set and dispatched at run time: one binary runs AVX-512 where the CPU has it, AVX2
// or SSE4 where not. What is declared here says which one a process uses, for benchmarks to
// label their figures and tests to check that forcing a target took.

namespace mrt {

/// Highway's name of the instruction set the block kernels run on now: "AVX3" (AVX-512),
/// "AVX2", "SSE4", "SSSE3" or "SCALAR" (one lane). The best the CPU supports, unless a test
/// restricts the choice (hwy::SetSupportedTargetsForTest).
const char* block_kernel_target();

}  // namespace mrt
