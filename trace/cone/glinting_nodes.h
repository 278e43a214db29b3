#pragma once
// Which nodes' points cannot hold their own highlight: those where some point's normals spread
// more than its Phong lobe is wide. A point's highlight is Toksvig's lobe of its normals' spread
// (OctreePoint::normal_length), exponent e widened to e' = e·ℓ/(ℓ + e·(1 − ℓ)); where that
// exponent falls to less than a half of e (the spread's variance (1 − ℓ)/ℓ above the lobe's 1/e)
// the surface under the point glints where the point shows a dull smear, and a mixture of such
// points (trace/cone/highlight_mixture.h) places its glints no better. A primary cone uses
// finer points there (ConeTraversalOptions::highlight_level_scale): a bumpy glass bunny under
// the sun, not a smooth sphere or a flat desk.

#include "common/hierarchy/hierarchy_file.h"

#include <cstdint>
#include <vector>

namespace mrt {

/// The least Toksvig widening e/e' − 1 = e·(1 − ℓ)/ℓ at which a point glints.
inline constexpr float kGlintWidening = 1.0f;

class GlintingNodes {
  public:
    explicit GlintingNodes(const HierarchyView& view);

    bool glinting(std::uint32_t node) const { return m_glinting[node] != 0; }

  private:
    std::vector<std::uint8_t> m_glinting;  ///< Per node.
};

}  // namespace mrt
