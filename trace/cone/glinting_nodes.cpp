#include "trace/cone/glinting_nodes.h"

#include "common/math/quantization.h"

namespace mrt {

GlintingNodes::GlintingNodes(const HierarchyView& view) : m_glinting(view.nodes.size(), 0) {
    if (view.specular.empty()) {
        return;  // no highlights at all
    }
    for (std::size_t n = 0; n < view.nodes.size(); ++n) {
        const HierarchyNode& node = view.nodes[n];
        for (std::uint32_t i = node.first_point; i < node.first_point + node.point_count; ++i) {
            const PointSpecular& specular = view.specular[i];
            if (specular.rgb[0] == 0 && specular.rgb[1] == 0 && specular.rgb[2] == 0) {
                continue;
            }
            const float exponent = decode_phong8(specular.phong);
            const float length = decode_normal_length8(view.diffuse[i].normal_length);
            if (exponent * (1.0f - length) > kGlintWidening * length) {
                m_glinting[n] = 1;
                break;
            }
        }
    }
}

}  // namespace mrt
