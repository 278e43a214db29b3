#pragma once
// The one scene loader: JSON scene file → mrt::Scene. Strict: unknown keys, wrong types and
// out-of-range values are errors naming the file, the JSON pointer of the value, what was found
// and what was expected. See docs/scene-format.md.

#include "common/scene/scene.h"
#include "common/system/budgets.h"

#include <filesystem>
#include <functional>
#include <string>

namespace mrt {

struct SceneLoadOptions {
    /// Receives warnings (e.g. degenerate triangles dropped); default prints nothing.
    std::function<void(const std::string&)> warn;
    /// Limits on the work the scene may ask for, checked before any geometry is generated or
    /// expanded: procedural-triangles (per shape), instances, instanced-triangles (also bounds
    /// the unique triangles stored), group-nesting (at most kMaxSupportedGroupNesting whatever
    /// the budget) and pixels (the camera's resolution).
    Budgets budgets;
};

/// Loads a scene file, the scene a hierarchy file (.mrh, recognised by its magic) stands for
/// (common/scene_io/hierarchy_scene.h), or the scene that frames a mesh file (.obj, .ply, .off,
/// .stl: common/scene_io/mesh_view.h). Throws mrt::Error on any problem.
Scene load_scene(const std::filesystem::path& file, const SceneLoadOptions& options = {});

/// A scene file's text; a missing or unreadable file is an error naming it.
std::string read_scene_text(const std::filesystem::path& file);

/// Parses scene JSON text as if it were the file `file` (paths resolve relative to its
/// directory). Used by tests and by tools that embed scenes.
Scene parse_scene(const std::string& json_text, const std::filesystem::path& file,
                  const SceneLoadOptions& options = {});

}  // namespace mrt
