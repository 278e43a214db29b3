#pragma once
// The scene record: everything of a Scene except its geometry — camera, lights, materials,
// textures, background, ambient and max_depth — as JSON text in the scene-file format
// (docs/scene-format.md), so that a hierarchy file can carry it and be rendered on its own.
// It is read back by the one scene loader, so it is exactly as strict as a scene file.
//
// Every number comes back with the same bits: floats are written as the shortest decimal that
// the loader turns back into the same float, the field of view as the degree value whose
// conversion gives back the stored radians, and a texture's uv transform as its "uv_matrix".
// Textures are written by their resolved absolute paths, which the loader resolves to
// themselves; the files must still exist when the record is loaded. Scene::world_origin is
// always written, as a double: it tells the loader that the camera and lights (and the geometry
// of the hierarchy file) are already relative to it, so they are not re-based again.

#include "common/scene/scene.h"
#include "common/system/budgets.h"

#include <filesystem>
#include <string>

namespace mrt {

/// The record of `scene`, compact JSON (one line): its top-level "objects" is empty and it has no
/// "groups". Throws mrt::Error when the scene holds something a scene file cannot say exactly: a
/// non-finite number, two materials of one name, a texture path that is not absolute and normal,
/// texture entries that are not those the loader would build from the materials (each referred
/// to, unique by path, srgb and channel, numbered in order of first use), or a uv transform on a
/// material without a texture. Values the loader rejects (a resolution of 0, say) are left to it.
/// The one value that comes back changed is a focal_distance of 0, which cameras take to mean the
/// distance to look_at: it comes back as that distance (computed by the loader, in double).
std::string scene_record_json(const Scene& scene);

/// The Scene of a record, through parse_scene as if the text were the file `file` (the path of
/// the hierarchy file, named by every error with the JSON pointer of the offending value). It
/// has no meshes and one empty group, the world, as a scene file with "objects": [] has. A record
/// with geometry in it is refused, and so is a camera over the `pixels` budget.
Scene load_scene_record(const std::string& json_text, const std::filesystem::path& file,
                        const Budgets& budgets = {});

}  // namespace mrt
