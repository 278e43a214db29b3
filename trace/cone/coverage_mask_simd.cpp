// samples_in_ellipse as a Highway kernel: hwy/foreach_target.h includes this file once per
// instruction set, HWY_DYNAMIC_DISPATCH calls the best the CPU has. The expression is the scalar
// reference's (ellipse_mask_scalar, trace/cone/coverage_mask.cpp) in the same order, and this
// file is compiled without fused multiply-adds (trace/cone/CMakeLists.txt), so the masks do not
// depend on the CPU.

#include "trace/cone/coverage_mask_simd.h"

#include <array>
#include <cstddef>
#include <cstdint>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "trace/cone/coverage_mask_simd.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace mrt {
namespace HWY_NAMESPACE {
namespace {

namespace hn = hwy::HWY_NAMESPACE;

CoverageMask samples_in_ellipse_simd(const CoverageSamples& samples, float cx, float cy, float xx,
                                     float xy, float yy) {
    const hn::CappedTag<float, 16> d;
    const std::size_t lanes = hn::Lanes(d);
    const auto centre_x = hn::Set(d, cx);
    const auto centre_y = hn::Set(d, cy);
    const auto form_xx = hn::Set(d, xx);
    const auto form_xy2 = hn::Set(d, 2.0f * xy);
    const auto form_yy = hn::Set(d, yy);
    const auto one = hn::Set(d, 1.0f);
    static_assert(hn::MaxLanes(decltype(d)()) <= 16);
    const std::uint64_t used = (std::uint64_t{1} << lanes) - 1;
    CoverageMask mask = 0;
    for (std::size_t k = 0; k < static_cast<std::size_t>(kCoverageSamples); k += lanes) {
        const auto dx = hn::Load(d, samples.x.data() + k) - centre_x;
        const auto dy = hn::Load(d, samples.y.data() + k) - centre_y;
        // ((xx·dx)·dx + ((2·xy)·dx)·dy) + (yy·dy)·dy, as the reference's C++ groups it.
        const auto q = (form_xx * dx * dx + form_xy2 * dx * dy) + form_yy * dy * dy;
        // At most 16 lanes: two bytes of bits, read a byte at a time (a word loaded across
        // several smaller stores is not forwarded from them: it stalled the first version at
        // 75 ns a mask, slower than the scalar loop).
        std::array<std::uint8_t, 8> bytes{};
        hn::StoreMaskBits(d, hn::Le(q, one), bytes.data());
        const std::uint64_t bits = std::uint64_t{bytes[0]} | (std::uint64_t{bytes[1]} << 8);
        mask |= (bits & used) << k;
    }
    return mask;
}

}  // namespace
}  // namespace HWY_NAMESPACE
}  // namespace mrt
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mrt {

HWY_EXPORT(samples_in_ellipse_simd);

CoverageMask samples_in_ellipse(const CoverageSamples& samples, float cx, float cy, float xx,
                                float xy, float yy) {
    return HWY_DYNAMIC_DISPATCH(samples_in_ellipse_simd)(samples, cx, cy, xx, xy, yy);
}

}  // namespace mrt
#endif  // HWY_ONCE
