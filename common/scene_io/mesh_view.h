#pragma once
// A scene around one mesh file, so that any mesh can be looked at without writing a scene:
// `mrt-trace mesh.obj -o out.png`. The scene is ordinary scene JSON (docs/scene-format.md,
// "Looking at a mesh"), printed by --print-scene for a user to save and edit.

#include "common/mesh/mesh_io.h"
#include "common/scene/scene_json.h"

#include <filesystem>
#include <string>

namespace mrt {

/// The mesh file `file` stands for: `file` itself where it exists, else looked for along the
/// data search path (resolve_data_file), absolute. Throws mrt::Error naming every place tried.
std::filesystem::path resolve_mesh_file(const std::filesystem::path& file);

/// The scene that frames the mesh in `file` (resolved by resolve_mesh_file; loaded once here
/// for its bounds): the camera looking at the centre of its bounding box from the front, right
/// and above (+z, +x, +y; y is up), far enough that the bounding sphere fills 80 % of the
/// frame's height; a grey material for every triangle; a checkerboard ground under the mesh
/// (its lowest y), eight bounding radii wide; a disc light above, in front and to the left,
/// and a little ambient light. Every length is a multiple of the bounding radius, so the same
/// mesh at any scale renders the same image.
Json mesh_view_scene(const std::filesystem::path& file);

/// The scene JSON that `file` stands for, as --print-scene prints it: a mesh file's framing
/// scene, or a scene file's own JSON (indented). A hierarchy file keeps no scene JSON: an error.
std::string printable_scene(const std::filesystem::path& file);

}  // namespace mrt
