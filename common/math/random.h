#pragma once
// Counter-based randomness: every sample's random numbers come from (seed, pixel, sample index,
// dimension) through a hash, so images do not depend on the thread schedule and a crop renders
// exactly the pixels of the full frame.

#include <cstdint>

namespace mrt {

/// 64-bit finaliser of MurmurHash3 / SplitMix64: a bijective avalanche mix.
constexpr std::uint64_t mix64(std::uint64_t x) {
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebULL;
    x ^= x >> 31;
    return x;
}

/// Element `index` of a pseudo-random permutation of [0, length) chosen by `key`, in O(1)
/// expected time and no memory (Kensler 2013, "Correlated Multi-Jittered Sampling", §3: a
/// hash that is a bijection on the next power of two, cycle-walked back into range).
constexpr std::uint32_t permute_index(std::uint32_t index, std::uint32_t length,
                                      std::uint32_t key) {
    std::uint32_t w = length - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    std::uint32_t i = index;
    do {
        i ^= key;
        i *= 0xe170893dU;
        i ^= key >> 16;
        i ^= (i & w) >> 4;
        i ^= key >> 8;
        i *= 0x0929eb3fU;
        i ^= key >> 23;
        i ^= (i & w) >> 1;
        i *= 1U | key >> 27;
        i *= 0x6935fa69U;
        i ^= (i & w) >> 11;
        i *= 0x74dcb303U;
        i ^= (i & w) >> 2;
        i *= 0x9e501cc3U;
        i ^= (i & w) >> 2;
        i *= 0xc860a3dfU;
        i &= w;
        i ^= i >> 5;
    } while (i >= length);
    return (i + key) % length;
}

/// Random stream for one sample: uniform floats in [0, 1) for successive dimensions.
class SampleRng {
  public:
    constexpr SampleRng(std::uint64_t seed, std::uint32_t pixel_x, std::uint32_t pixel_y,
                        std::uint32_t sample_index)
        : m_state(mix64(seed ^ mix64((static_cast<std::uint64_t>(pixel_x) << 32) ^ pixel_y) ^
                        mix64(0x9e3779b97f4a7c15ULL * (sample_index + 1ULL)))) {}

    /// Uniform in [0, 1), 24 random bits (exactly representable, never 1).
    constexpr float uniform() {
        m_dimension += 1;
        const std::uint64_t bits = mix64(m_state + 0x9e3779b97f4a7c15ULL * m_dimension);
        return static_cast<float>(bits >> 40) * 0x1.0p-24f;
    }

  private:
    std::uint64_t m_state;
    std::uint64_t m_dimension = 0;
};

}  // namespace mrt
