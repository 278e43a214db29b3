#include "common/scene_io/mesh_view.h"

#include "common/hierarchy/section_file.h"
#include "common/mesh/mesh_io.h"
#include "common/scene_io/data_path.h"
#include "common/scene_io/scene_loader.h"
#include "common/system/error.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

namespace mrt {

namespace {

/// Vertical field of view, degrees.
constexpr double kFieldOfView = 40.0;
/// Share of the frame's height the bounding sphere fills.
constexpr double kFill = 0.8;
/// Where the camera looks from, relative to the centre: the three-quarter view from front,
/// right and above in which most scanned and modelled objects are recognisable.
const Vec3d kViewDirection = Vec3d(0.55, 0.45, 1.0).normalized();
/// The ground's width and depth, in bounding radii.
constexpr double kGroundRadii = 8.0;
constexpr int kGroundTiles = 8;
/// The light: a disc of one bounding radius, this many radii from the centre, toward the
/// front left and above; its radiance gives an irradiance of about kLightIrradiance facing it.
const Vec3d kLightDirection = Vec3d(-0.6, 1.0, 0.5).normalized();
constexpr double kLightDistanceRadii = 4.0;
constexpr double kLightIrradiance = 3.0;
/// Faces of a mesh without normals that meet at more than this are not smoothed across, so a box
/// (the Cornell box) keeps flat walls; a scan's ridges are smoother than that.
constexpr double kViewCreaseAngleDegrees = 60.0;

Json json_of(const Vec3d& v) {
    return Json::array({v.x(), v.y(), v.z()});
}

}  // namespace

std::filesystem::path resolve_mesh_file(const std::filesystem::path& file) {
    const std::filesystem::path here = std::filesystem::current_path();
    if (const auto found = resolve_data_file(file.string(), here)) {
        return *found;
    }
    std::string looked;
    for (const auto& candidate : data_file_candidates(file.string(), here)) {
        looked += (looked.empty() ? "" : ", ") + candidate.string();
    }
    throw Error(file, "", "mesh file not found (looked in: " + looked + ")");
}

Json mesh_view_scene(const std::filesystem::path& file) {
    const std::filesystem::path mesh_file = resolve_mesh_file(file);
    const Eigen::AlignedBox3d box = load_mesh(mesh_file, 0).mesh.bounds().cast<double>();
    const Vec3d centre = box.center();
    // A flat or single-point mesh still gets a camera at a finite distance.
    const double radius = std::max(0.5 * box.diagonal().norm(), 1e-3);

    const double half_angle = 0.5 * kFieldOfView * std::numbers::pi / 180.0;
    const double distance = radius / (kFill * std::sin(half_angle));
    const double light_distance = kLightDistanceRadii * radius;
    // A disc of radius a at distance d facing the point gives E = L·π·a²/(d² + a²).
    const double light_radiance = kLightIrradiance *
                                  (light_distance * light_distance + radius * radius) /
                                  (std::numbers::pi * radius * radius);
    // The disc faces the centre: its normal u × v = side × (side × l) = −l.
    const Vec3d side = Vec3d(kLightDirection.z(), 0.0, -kLightDirection.x()).normalized();
    const Vec3d up = side.cross(kLightDirection);

    Json scene;
    scene["camera"] = {{"eye", json_of(centre + distance * kViewDirection)},
                       {"look_at", json_of(centre)},
                       {"up", json_of(Vec3d::UnitY())},
                       {"fov", kFieldOfView},
                       {"resolution", Json::array({640, 480})}};
    scene["background"] = json_of(Vec3d(0.45, 0.55, 0.7));
    scene["ambient"] = json_of(Vec3d(0.08, 0.08, 0.09));
    scene["max_depth"] = 4;
    scene["materials"] = {{"mesh",
                           {{"diffuse", json_of(Vec3d(0.7, 0.7, 0.68))},
                            {"specular", json_of(Vec3d::Constant(0.15))},
                            {"phong_exponent", 40}}},
                          {"ground_light", {{"diffuse", json_of(Vec3d(0.6, 0.6, 0.58))}}},
                          {"ground_dark", {{"diffuse", json_of(Vec3d(0.35, 0.35, 0.34))}}}};
    scene["lights"] = Json::array({{{"type", "ellipse"},
                                    {"center", json_of(centre + light_distance * kLightDirection)},
                                    {"semi_axis_u", json_of(radius * side)},
                                    {"semi_axis_v", json_of(radius * up)},
                                    {"radiance", light_radiance}}});
    const double ground_size = kGroundRadii * radius;
    scene["objects"] = Json::array(
        {{{"shape", "mesh"},
          {"file", mesh_file.string()},
          {"material", "mesh"},
          {"crease_angle", kViewCreaseAngleDegrees}},
         {{"shape", "checkerboard"},
          {"size", Json::array({ground_size, ground_size})},
          {"tiles", Json::array({kGroundTiles, kGroundTiles})},
          {"materials", Json::array({"ground_light", "ground_dark"})},
          {"transform", {{"translate", json_of(Vec3d(centre.x(), box.min().y(), centre.z()))}}}}});
    return scene;
}

std::string printable_scene(const std::filesystem::path& file) {
    if (is_mesh_file(file)) {
        return mesh_view_scene(file).dump(2);
    }
    if (starts_like_section_file(file)) {
        throw Error(file, "",
                    "is a hierarchy file, which keeps no scene JSON to print (expected a scene "
                    "or mesh file)");
    }
    return parse_json_text(read_scene_text(file), file).dump(2);
}

}  // namespace mrt
