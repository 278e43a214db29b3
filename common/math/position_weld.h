#pragma once
// Welding vertices by position: files split vertices at texture seams and between patches, STL
// shares none, and generators duplicate a seam's vertices for its uvs, yet each such group is
// one point of the surface.

#include "common/math/math.h"

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

namespace mrt {

namespace detail {

struct PositionKey {
    std::array<std::uint32_t, 3> bits;
    bool operator==(const PositionKey&) const = default;
};

struct PositionKeyHash {
    std::size_t operator()(const PositionKey& k) const {
        std::uint64_t h = 0xcbf29ce484222325ULL;
        for (const std::uint32_t b : k.bits) {
            h = (h ^ b) * 0x100000001b3ULL;
        }
        return static_cast<std::size_t>(h);
    }
};

}  // namespace detail

/// For vertices 0 … count − 1 at `position(v)` (a Vec3f): each one's welded index, dense from 0
/// in order of first appearance, equal for bitwise equal positions (−0 and +0 alike).
/// `representative` receives, per welded index, the first vertex at that position.
template <class Position>
std::vector<std::uint32_t> weld_positions(std::size_t count, Position&& position,
                                          std::vector<std::uint32_t>& representative) {
    std::unordered_map<detail::PositionKey, std::uint32_t, detail::PositionKeyHash> index;
    index.reserve(count);
    std::vector<std::uint32_t> welded(count);
    representative.clear();
    for (std::size_t v = 0; v < count; ++v) {
        // Adding +0 turns −0 into +0, so that the two zeros weld.
        const Vec3f p = Vec3f(position(v)) + Vec3f::Zero();
        const detail::PositionKey key{{std::bit_cast<std::uint32_t>(p.x()),
                                       std::bit_cast<std::uint32_t>(p.y()),
                                       std::bit_cast<std::uint32_t>(p.z())}};
        const auto [it, inserted] =
            index.try_emplace(key, static_cast<std::uint32_t>(representative.size()));
        if (inserted) {
            representative.push_back(static_cast<std::uint32_t>(v));
        }
        welded[v] = it->second;
    }
    return welded;
}

}  // namespace mrt
