#pragma once
// Which mesh objects each object of a hierarchy file stands for: a mesh itself, a group every
// mesh its instances hold, through nested groups. A group's points stand for all of them at
// once (coarse levels of the field's ground: one point for many boards), so a cone leaving a
// mesh can take a group's points for the surface it leaves only where the group holds that mesh
// (trace/cone/cone_traversal.cpp, may_be_left).

#include "common/hierarchy/hierarchy_file.h"

#include <cstdint>
#include <vector>

namespace mrt {

class MeshesBelow {
  public:
    explicit MeshesBelow(const HierarchyView& view);

    /// Whether `object`'s primitives and points may stand for mesh object `mesh`.
    bool holds(std::uint32_t object, std::uint32_t mesh) const;

  private:
    std::vector<std::vector<std::uint32_t>> m_meshes;  ///< Per object, sorted.
};

}  // namespace mrt
