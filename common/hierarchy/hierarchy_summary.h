#pragma once
// What a hierarchy file holds, as text for people: objects and instances, channels, nodes,
// points and triangles (or instances) per level of mesh and of group objects, and the bytes of
// every section. mrt-info prints it, and mrt-preprocess after writing a file.

#include "common/hierarchy/hierarchy_file.h"

#include <string>

namespace mrt {

/// Lines ending in '\n', each indented by `indent`.
std::string hierarchy_summary(const HierarchyFile& file, const std::string& indent = "");

}  // namespace mrt
