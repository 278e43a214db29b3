#include "common/scene_io/mesh_view.h"

#include "common/hierarchy/section_file.h"
#include "common/mesh/mesh_io.h"
#include "common/scene_io/data_path.h"
#include "common/system/error.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

namespace mrt {

namespace {

/// Vertical field of view, degrees.
constexpr double kFieldOfView = 40.0;
/// Share of the frame's height the bounding sphere fills.
constexpr double kFill = 0.8;
/// Where the camera looks from, relative to the centre (normalised): the three-quarter view
/// from front, right and above in which most scanned and modelled objects are recognisable.
constexpr std::array<double, 3> kViewDirection = {0.55, 0.45, 1.0};
/// The ground's width and depth, in bounding radii.
constexpr double kGroundRadii = 8.0;
constexpr int kGroundTiles = 8;
/// The light: a disc of one bounding radius, this many radii from the centre, toward the
/// front left and above; its radiance gives an irradiance of about kLightIrradiance facing it.
constexpr std::array<double, 3> kLightDirection = {-0.6, 1.0, 0.5};
constexpr double kLightDistanceRadii = 4.0;
constexpr double kLightIrradiance = 3.0;

Json vec3(double x, double y, double z) {
    return Json::array({x, y, z});
}

std::array<double, 3> normalised(const std::array<double, 3>& v) {
    const double length = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    return {v[0] / length, v[1] / length, v[2] / length};
}

}  // namespace

std::filesystem::path resolve_mesh_file(const std::filesystem::path& file) {
    std::error_code error;
    if (std::filesystem::is_regular_file(file, error)) {
        return std::filesystem::absolute(file);
    }
    if (const auto found = resolve_data_file(file.string(), std::filesystem::current_path())) {
        return *found;
    }
    std::string tried = file.string();
    for (const std::filesystem::path& dir : data_search_path()) {
        tried += ", " + (dir / file).string();
    }
    throw Error(file, "", "mesh file not found (looked in: " + tried + ")");
}

Json mesh_view_scene(const std::filesystem::path& file) {
    const std::filesystem::path mesh_file = resolve_mesh_file(file);
    const Mesh mesh = load_mesh(mesh_file, 0).mesh;
    const Eigen::AlignedBox3f box = mesh.bounds();
    const Vec3f centre_f = box.center();
    const std::array<double, 3> centre = {centre_f.x(), centre_f.y(), centre_f.z()};
    // A flat or single-point mesh still gets a camera at a finite distance.
    const double radius = std::max(0.5 * static_cast<double>(box.diagonal().norm()), 1e-3);
    const double ground = static_cast<double>(box.min().y());

    const double half_angle = 0.5 * kFieldOfView * std::numbers::pi / 180.0;
    const double distance = radius / (kFill * std::sin(half_angle));
    const std::array<double, 3> view = normalised(kViewDirection);
    const std::array<double, 3> to_light = normalised(kLightDirection);
    const double light_distance = kLightDistanceRadii * radius;
    // A disc of radius a at distance d facing the point gives E = L·π·a²/(d² + a²).
    const double light_radiance = kLightIrradiance *
                                  (light_distance * light_distance + radius * radius) /
                                  (std::numbers::pi * radius * radius);
    // The disc faces the centre: its normal u × v points back along to_light.
    const std::array<double, 3> side = normalised({to_light[2], 0.0, -to_light[0]});
    const std::array<double, 3> up = {side[1] * to_light[2] - side[2] * to_light[1],
                                      side[2] * to_light[0] - side[0] * to_light[2],
                                      side[0] * to_light[1] - side[1] * to_light[0]};

    Json scene;
    scene["camera"] = {{"eye", vec3(centre[0] + distance * view[0], centre[1] + distance * view[1],
                                    centre[2] + distance * view[2])},
                       {"look_at", vec3(centre[0], centre[1], centre[2])},
                       {"up", vec3(0, 1, 0)},
                       {"fov", kFieldOfView},
                       {"resolution", Json::array({640, 480})}};
    scene["background"] = vec3(0.45, 0.55, 0.7);
    scene["ambient"] = vec3(0.08, 0.08, 0.09);
    scene["max_depth"] = 4;
    scene["materials"] = {{"mesh",
                           {{"diffuse", vec3(0.7, 0.7, 0.68)},
                            {"specular", vec3(0.15, 0.15, 0.15)},
                            {"phong_exponent", 40}}},
                          {"ground_light", {{"diffuse", vec3(0.6, 0.6, 0.58)}}},
                          {"ground_dark", {{"diffuse", vec3(0.35, 0.35, 0.34)}}}};
    scene["lights"] =
        Json::array({{{"type", "ellipse"},
                      {"center", vec3(centre[0] + light_distance * to_light[0],
                                      centre[1] + light_distance * to_light[1],
                                      centre[2] + light_distance * to_light[2])},
                      {"semi_axis_u", vec3(radius * side[0], radius * side[1], radius * side[2])},
                      {"semi_axis_v", vec3(radius * up[0], radius * up[1], radius * up[2])},
                      {"radiance", light_radiance}}});
    const double ground_size = kGroundRadii * radius;
    scene["objects"] =
        Json::array({{{"shape", "mesh"}, {"file", mesh_file.string()}, {"material", "mesh"}},
                     {{"shape", "checkerboard"},
                      {"size", Json::array({ground_size, ground_size})},
                      {"tiles", Json::array({kGroundTiles, kGroundTiles})},
                      {"materials", Json::array({"ground_light", "ground_dark"})},
                      {"transform", {{"translate", vec3(centre[0], ground, centre[2])}}}}});
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
    std::ifstream in(file, std::ios::binary);
    if (!in) {
        throw Error(file, "", "scene file not found");
    }
    std::ostringstream text;
    text << in.rdbuf();
    return parse_json_text(text.str(), file).dump(2);
}

}  // namespace mrt
