#include "common/scene_io/scene_loader.h"

#include "common/hierarchy/section_file.h"
#include "common/math/invertibility.h"
#include "common/mesh/mesh_io.h"
#include "common/mesh/mtl_library.h"
#include "common/mesh/procedural.h"
#include "common/scene/emissive_lights.h"
#include "common/scene/object_scale.h"
#include "common/scene/scene_json.h"
#include "common/scene/world_origin.h"
#include "common/scene_io/data_path.h"
#include "common/scene_io/hierarchy_scene.h"
#include "common/scene_io/mesh_view.h"
#include "common/scene_io/mtl_materials.h"
#include "common/system/budgets.h"
#include "common/system/error.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <span>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace mrt {

namespace {

constexpr int kMaxResolution = 65536;
constexpr int kMaxBounces = 1000;
constexpr int kMaxSegments = 65536;
constexpr int kMaxTiles = 65536;
constexpr int kMaxPlantSeed = std::numeric_limits<int>::max();
constexpr double kRadiansPerDegree = std::numbers::pi / 180.0;
constexpr float kDefaultVerticalFovDegrees = 45.0f;
// Pixel width over height: anamorphic formats stay within 1:4 .. 4:1; beyond 1:100 the
// footprints' anisotropy clamp, not the camera, would decide what a pixel sees.
constexpr double kMinPixelAspect = 0.01;
constexpr double kMaxPixelAspect = 100.0;
// Below this sine of the angle between up and the view direction the camera basis is undefined.
constexpr double kMinUpViewSine = 1e-6;

/// A mesh file to load once every other value of the scene has been validated.
struct PendingMeshFile {
    std::uint32_t mesh = 0;  ///< Slot in Scene::meshes.
    std::filesystem::path path;
    /// For faces the file gives no material (none: the default material).
    std::optional<std::uint32_t> material;
    double crease_angle = kSmoothEverywhere;  ///< Radians.
    std::string pointer;                      ///< Of the "file" value, for messages.
};

/// A procedural shape to generate once the whole scene is known to be within its budgets.
struct PendingProcedural {
    std::uint32_t mesh = 0;  ///< Slot in Scene::meshes.
    std::string pointer;     ///< Of the shape's object, for messages.
    std::function<Mesh()> make;
};

/// One {"instance": name} of a group, kept for the cycle check.
struct GroupReference {
    std::uint32_t group = 0;
    std::string pointer;  ///< Of the "instance" value.
};

std::string join(const std::vector<std::string>& parts, std::string_view separator) {
    std::string out;
    for (std::size_t i = 0; i < parts.size(); ++i) {
        out += (i == 0 ? "" : std::string(separator)) + parts[i];
    }
    return out;
}

std::string expected_names(const std::map<std::string, std::uint32_t>& names,
                           std::string_view what) {
    if (names.empty()) {
        return fmt::format("no {} are defined", what);
    }
    std::vector<std::string> keys;
    keys.reserve(names.size());
    for (const auto& entry : names) {
        keys.push_back(entry.first);
    }
    return "expected one of: " + join_names(std::move(keys));
}

/// Exactly one of two alternative keys (e.g. "intensity" or "power"); second = the first key.
std::pair<JsonValue, bool> exactly_one_of(const JsonObject& object, std::string_view first,
                                          std::string_view second) {
    const auto a = object.optional(first);
    const auto b = object.optional(second);
    if (a && b) {
        b->fail(fmt::format("found both \"{}\" and \"{}\", expected exactly one of them", first,
                            second));
    }
    if (!a && !b) {
        object.value().fail(
            fmt::format("missing required key \"{}\" or \"{}\" (exactly one)", first, second));
    }
    return a ? std::pair{*a, true} : std::pair{*b, false};
}

/// An array of 3 numbers in double precision: positions are re-based before they are rounded
/// (common/scene/world_origin.h). Refused exactly as JsonValue::vec3 refuses.
Vec3d read_point(const JsonValue& value) {
    if (!value.json().is_array() || value.json().size() != 3) {
        value.fail_expected("an array of 3 numbers");
    }
    const auto elements = value.elements();
    return {elements[0].double_number(), elements[1].double_number(), elements[2].double_number()};
}

Eigen::Matrix3d read_axis_angle(const JsonValue& value) {
    const JsonObject rotation(value, {"axis", "degrees"});
    const Eigen::Vector3d axis = rotation.required("axis").nonzero_vec3().cast<double>();
    const double degrees = rotation.required("degrees").number();
    return Eigen::AngleAxisd(degrees * kRadiansPerDegree, axis.normalized()).toRotationMatrix();
}

Eigen::Matrix3d read_rotation(const JsonValue& value) {
    if (value.json().is_array()) {
        Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
        for (const JsonValue& step : value.elements()) {
            rotation = read_axis_angle(step) * rotation;
        }
        return rotation;
    }
    if (!value.json().is_object()) {
        value.fail_expected(R"(an object {"axis": [x, y, z], "degrees": a} or an array of them)");
    }
    return read_axis_angle(value);
}

Eigen::Vector3d read_scale(const JsonValue& value) {
    if (value.json().is_number()) {
        return Eigen::Vector3d::Constant(value.nonzero_number());
    }
    if (!value.json().is_array() || value.json().size() != 3) {
        value.fail_expected("a non-zero number or an array of 3 non-zero numbers");
    }
    const auto elements = value.elements();
    return {elements[0].nonzero_number(), elements[1].nonzero_number(),
            elements[2].nonzero_number()};
}

Affine3d read_matrix(const JsonValue& value) {
    constexpr std::string_view kExpected = "an array of 16 numbers (4x4, row-major)";
    if (!value.json().is_array() || value.json().size() != 16) {
        value.fail_expected(kExpected);
    }
    const auto elements = value.elements();
    Eigen::Matrix4d matrix;
    for (int row = 0; row < 4; ++row) {
        for (int column = 0; column < 4; ++column) {
            matrix(row, column) =
                elements[static_cast<std::size_t>(4 * row + column)].double_number();
        }
    }
    if (matrix.row(3) != Eigen::RowVector4d(0.0, 0.0, 0.0, 1.0)) {
        value.fail_expected("a last row of 0, 0, 0, 1 (an affine matrix)");
    }
    // Scale-free: a matrix of huge or tiny (even non-uniform) scale is invertible.
    if (!(scaling_invariant_condition(matrix.topLeftCorner<3, 3>()) <=
          kMaxScalingInvariantCondition)) {
        value.fail_expected("an invertible matrix");
    }
    Affine3d transform;
    transform.matrix() = matrix;
    return transform;
}

Affine3d read_transform_step(const JsonValue& value) {
    const JsonObject step(value, {"matrix", "rotate", "scale", "translate"});
    if (const auto matrix = step.optional("matrix")) {
        for (const char* other : {"rotate", "scale", "translate"}) {
            if (const auto conflicting = step.optional(other)) {
                conflicting->fail(R"(cannot be combined with "matrix" (expected either "matrix" )"
                                  R"(or any of "scale", "rotate", "translate"))");
            }
        }
        return read_matrix(*matrix);
    }
    // Eigen's translate/rotate/scale multiply on the right: the result is T·R·S.
    Affine3d transform = Affine3d::Identity();
    if (const auto translate = step.optional("translate")) {
        transform.translate(read_point(*translate));
    }
    if (const auto rotate = step.optional("rotate")) {
        transform.rotate(read_rotation(*rotate));
    }
    if (const auto scale = step.optional("scale")) {
        transform.scale(read_scale(*scale));
    }
    return transform;
}

/// The composed transform, in double: rotations by right angles come out exact in single
/// precision, and a world placement far from the origin keeps its digits until it is re-based.
Affine3d read_transform(const JsonValue& value) {
    Affine3d transform = Affine3d::Identity();
    if (value.json().is_array()) {
        for (const JsonValue& step : value.elements()) {
            transform = read_transform_step(step) * transform;
        }
    } else if (value.json().is_object()) {
        transform = read_transform_step(value);
    } else {
        value.fail_expected("a transform object or an array of them");
    }
    return transform;
}

/// `composed` moved into the scene's space by `frame` and rounded to float; `where` is the
/// transform's value (or the object's, when it has none). Invertibility is decided scale-free
/// (common/math/invertibility.h): uniform scales of 1e13 or 1e-30 are accepted, singular or
/// unrepresentable linear parts refused.
Affine3f single_precision_transform(const JsonValue& where, const Affine3d& composed,
                                    const WorldFrame& frame) {
    if (!invertible_in_single_precision(composed.linear())) {
        where.fail(
            "the composed transform is not invertible in single precision (expected an "
            "invertible transform)");
    }
    const Affine3f result = frame.placement(composed);
    if (!all_finite(result.translation())) {
        where.fail(
            "the composed transform's translation is beyond single precision (expected a "
            "translation within 3.4e38 of the scene's origin)");
    }
    return result;
}

/// {"uv_matrix": [9 numbers]}: 3×3, row-major, affine and invertible. Any Material::uv_transform
/// can be written this way exactly (scene records do).
Affine2f read_uv_matrix(const JsonValue& value) {
    const std::vector<float> m = value.numbers(9, "an array of 9 numbers (3x3, row-major)");
    if (m[6] != 0.0f || m[7] != 0.0f || m[8] != 1.0f) {
        value.fail_expected("a last row of 0, 0, 1 (an affine matrix)");
    }
    Eigen::Matrix2f linear;
    linear << m[0], m[1], m[3], m[4];
    // In double, where products of floats are exact: tiny but valid scales do not underflow.
    if (linear.cast<double>().determinant() == 0.0) {
        value.fail_expected("an invertible matrix");
    }
    Affine2f transform = Affine2f::Identity();
    transform.linear() = linear;
    transform.translation() = Vec2f(m[2], m[5]);
    return transform;
}

/// The uv transform of a texture object: "uv_matrix", or "uv_scale", "uv_rotate", "uv_offset".
Affine2f read_uv_transform(const JsonObject& texture) {
    if (const auto matrix = texture.optional("uv_matrix")) {
        for (const char* other : {"uv_offset", "uv_rotate", "uv_scale"}) {
            if (const auto conflicting = texture.optional(other)) {
                conflicting->fail(R"(cannot be combined with "uv_matrix" (expected either )"
                                  R"("uv_matrix" or any of "uv_scale", "uv_rotate", "uv_offset"))");
            }
        }
        return read_uv_matrix(*matrix);
    }
    Vec2f scale(1.0f, 1.0f);
    if (const auto uv_scale = texture.optional("uv_scale")) {
        scale = uv_scale->vec2_or_number();
        if (scale.x() == 0.0f || scale.y() == 0.0f) {
            uv_scale->fail_expected("a non-zero number or an array of 2 non-zero numbers");
        }
    }
    const auto uv_offset = texture.optional("uv_offset");
    const Vec2f offset = uv_offset ? uv_offset->vec2() : Vec2f(0.0f, 0.0f);
    const auto uv_rotate = texture.optional("uv_rotate");
    const double degrees = uv_rotate ? uv_rotate->number() : 0.0;

    // uv' = translate(offset) · rotate · scale(uv).
    Affine2f transform = Affine2f::Identity();
    transform.translate(offset)
        .rotate(Eigen::Rotation2Df(static_cast<float>(degrees * kRadiansPerDegree)))
        .scale(scale);
    return transform;
}

/// Refuses a scene whose groups, expanded, are over the budgets: nesting (never deeper than
/// kMaxSupportedGroupNesting), mesh placements and their triangles, and the unique triangles
/// stored. `group_location(g)` names group g in messages; `objects` is where the world's
/// instances are written. Nothing is expanded: the counts come from expand_groups.
void check_expansion(const Scene& scene, std::span<const std::uint64_t> mesh_triangles,
                     const Budgets& budgets,
                     const std::function<std::string(std::uint32_t)>& group_location,
                     const std::string& objects) {
    if (scene.root >= scene.groups.size()) {
        return;
    }
    const std::vector<GroupExpansion> expansion = expand_groups(scene, mesh_triangles);
    const GroupExpansion& world = expansion[scene.root];
    const std::uint64_t nesting_limit = std::min(budgets.group_nesting, kMaxSupportedGroupNesting);
    if (world.levels > nesting_limit) {
        // Down the deepest chain to the first group beyond the limit.
        std::uint32_t group = scene.root;
        for (std::uint64_t level = 1; level <= nesting_limit; ++level) {
            for (const Instance& child : scene.groups[group].children) {
                if (child.kind == Instance::Kind::Group &&
                    expansion[child.index].levels + 1 == expansion[group].levels) {
                    group = child.index;
                    break;
                }
            }
        }
        const std::string location = group_location(group);
        check_budget(budgets, "group-nesting", world.levels, "levels of group nesting", scene.file,
                     location);
        throw Error(scene.file, location,
                    fmt::format("the scene asks for {} levels of group nesting, over the {} "
                                "levels every tool supports (whatever --budget group-nesting says)",
                                world.levels, kMaxSupportedGroupNesting));
    }
    check_budget(budgets, "instances", world.instances, "mesh instances (groups expanded)",
                 scene.file, objects);
    check_budget(budgets, "instanced-triangles", world.triangles, "triangles (instances expanded)",
                 scene.file, objects);
    std::uint64_t unique = 0;
    for (const std::uint64_t triangles : mesh_triangles) {
        unique = saturating_add(unique, triangles);
    }
    check_budget(budgets, "instanced-triangles", unique, "triangles of unique geometry", scene.file,
                 "");
}

class SceneBuilder {
  public:
    SceneBuilder(const std::filesystem::path& file, const SceneLoadOptions& options)
        : m_file(file), m_directory(file.parent_path()), m_options(options) {}

    Scene build(const Json& document) {
        const JsonValue root(m_file, document, "");
        const JsonObject top(root, {"ambient", "background", "camera", "groups", "lights",
                                    "materials", "max_depth", "objects", "world_origin"});
        m_scene.file = m_file;
        read_camera(top.required("camera"), top.optional("world_origin"));
        if (const auto background = top.optional("background")) {
            m_scene.background = background->colour();
        }
        if (const auto ambient = top.optional("ambient")) {
            m_scene.ambient = ambient->colour();
        }
        if (const auto max_depth = top.optional("max_depth")) {
            m_scene.max_depth = max_depth->integer(0, kMaxBounces);
        }
        if (const auto materials = top.optional("materials")) {
            read_materials(*materials);
        }
        if (const auto lights = top.optional("lights")) {
            read_lights(*lights);
        }
        read_groups(top.optional("groups"), top.required("objects"));
        check_group_cycles();
        load_mesh_files();
        check_expansion(
            m_scene, m_mesh_triangles, m_options.budgets,
            [this](std::uint32_t group) {
                return "/groups/" + pointer_token(m_scene.groups[group].name);
            },
            "/objects");
        make_procedural_meshes();
        normalize_object_scales(m_scene);
        m_scene.mesh_lights = emissive_lights(m_scene);
        return std::move(m_scene);
    }

  private:
    void read_camera(const JsonValue& value, const std::optional<JsonValue>& world_origin) {
        const JsonObject camera(value, {"aperture_radius", "eye", "focal_distance", "fov",
                                        "look_at", "pixel_aspect", "resolution", "up"});
        Camera& c = m_scene.camera;
        const Vec3d eye_position = read_point(camera.required("eye"));
        const JsonValue look_at = camera.required("look_at");
        const Vec3d look_at_position = read_point(look_at);
        choose_frame(world_origin, eye_position, look_at_position);
        c.eye = m_frame.point(eye_position);
        c.look_at = m_frame.point(look_at_position);
        if (!all_finite(c.look_at)) {
            look_at.fail_expected("a point within single-precision range of \"eye\"");
        }
        const Eigen::Vector3d view = c.look_at.cast<double>() - c.eye.cast<double>();
        if (view.isZero(0.0)) {
            look_at.fail_expected("a point different from \"eye\"");
        }
        const auto up = camera.optional("up");
        c.up = up ? up->nonzero_vec3() : Vec3f(0.0f, 1.0f, 0.0f);
        const double sine = view.normalized().cross(c.up.cast<double>().normalized()).norm();
        if (!(sine > kMinUpViewSine)) {
            if (up) {
                up->fail_expected("a vector not parallel to the view direction (look_at - eye)");
            }
            value.fail(R"(the default "up" [0, 1, 0] is parallel to the view direction )"
                       R"((look_at - eye); expected an explicit "up")");
        }
        const auto fov = camera.optional("fov");
        // Degrees rounded to float first would be rounded twice, and about one float angle in
        // eleven could then not be written at all (scene records write every angle exactly).
        c.vertical_fov = static_cast<float>(
            (fov ? fov->double_number(NumberRange::open(0.0, 180.0)) : kDefaultVerticalFovDegrees) *
            kRadiansPerDegree);
        if (const auto resolution = camera.optional("resolution")) {
            const std::string expected = "an array of 2 integers (width, height)";
            const auto size = resolution->elements(expected);
            if (size.size() != 2) {
                resolution->fail_expected(expected);
            }
            c.width = size[0].integer(1, kMaxResolution);
            c.height = size[1].integer(1, kMaxResolution);
        }
        check_budget(m_options.budgets, "pixels",
                     saturating_mul(static_cast<std::uint64_t>(c.width),
                                    static_cast<std::uint64_t>(c.height)),
                     "pixels (camera resolution)", m_file, value.pointer() + "/resolution");
        if (const auto aspect = camera.optional("pixel_aspect")) {
            c.pixel_aspect = aspect->number(NumberRange::closed(kMinPixelAspect, kMaxPixelAspect));
        }
        if (const auto aperture = camera.optional("aperture_radius")) {
            c.aperture_radius = aperture->number(NumberRange::at_least(0.0));
        }
        const auto focal_distance = camera.optional("focal_distance");
        c.focal_distance = focal_distance ? focal_distance->number(NumberRange::above(0.0))
                                          : static_cast<float>(view.norm());
        if (!std::isfinite(c.focal_distance)) {
            look_at.fail_expected("a point within single-precision range of \"eye\"");
        }
    }

    // A file that says where its origin is keeps its coordinates (a scene record's geometry, in
    // its hierarchy file, is already relative to that origin); any other is re-based on the eye
    // when the eye is far from the file's origin (common/scene/world_origin.h).
    void choose_frame(const std::optional<JsonValue>& world_origin, const Vec3d& eye,
                      const Vec3d& look_at) {
        if (world_origin) {
            m_scene.world_origin = read_point(*world_origin);
            return;
        }
        m_frame = WorldFrame(choose_world_origin(eye, look_at));
        m_scene.world_origin = m_frame.origin();
    }

    /// A world position of the file (a light's), in the scene's space.
    Vec3f world_point(const JsonValue& value) const {
        const Vec3f point = m_frame.point(read_point(value));
        if (!all_finite(point)) {
            value.fail_expected("a point within single-precision range of the camera's \"eye\"");
        }
        return point;
    }

    void read_materials(const JsonValue& value) {
        for (const auto& [name, material] : value.members("an object of named materials")) {
            m_material_index.emplace(name, static_cast<std::uint32_t>(m_scene.materials.size()));
            m_scene.materials.push_back(read_material(name, material));
        }
    }

    Material read_material(const std::string& name, const JsonValue& value) {
        const JsonObject object(
            value, {"diffuse", "emission", "ior", "opacity_texture", "phong_exponent",
                    "reflectivity", "roughness", "specular", "texture", "transparency"});
        Material m;
        m.name = name;
        if (const auto diffuse = object.optional("diffuse")) {
            m.diffuse = diffuse->colour();
        }
        if (const auto specular = object.optional("specular")) {
            m.specular = specular->colour();
        }
        if (const auto emission = object.optional("emission")) {
            m.emission = emission->colour();
        }
        if (const auto exponent = object.optional("phong_exponent")) {
            m.phong_exponent = exponent->number(NumberRange::at_least(0.0));
        }
        if (const auto reflectivity = object.optional("reflectivity")) {
            m.reflectivity = reflectivity->number(NumberRange::closed(0.0, 1.0));
        }
        if (const auto transparency = object.optional("transparency")) {
            m.transparency = transparency->number(NumberRange::closed(0.0, 1.0));
        }
        // Decimal fractions such as 0.7 + 0.3 may round to just above 1.
        constexpr double kSumTolerance = 1e-6;
        const double sum = static_cast<double>(m.reflectivity) + m.transparency;
        if (sum > 1.0 + kSumTolerance) {
            value.fail(fmt::format("reflectivity + transparency = {}, expected at most 1",
                                   static_cast<float>(sum)));
        }
        if (const auto ior = object.optional("ior")) {
            m.ior = ior->number(NumberRange::above(0.0));
        }
        if (const auto roughness = object.optional("roughness")) {
            m.roughness = roughness->number(NumberRange::at_least(0.0));
        }
        const auto texture = object.optional("texture");
        if (texture) {
            read_texture(*texture, m);
        }
        if (const auto opacity = object.optional("opacity_texture")) {
            read_opacity_texture(*opacity, m, texture.has_value());
        }
        return m;
    }

    void read_texture(const JsonValue& value, Material& material) {
        const JsonObject object(
            value, {"file", "srgb", "uv_matrix", "uv_offset", "uv_rotate", "uv_scale"});
        const std::filesystem::path path = resolve(object.required("file"));
        const auto srgb_value = object.optional("srgb");
        const bool srgb = srgb_value ? srgb_value->boolean() : true;
        material.uv_transform = read_uv_transform(object);

        material.texture = texture_index(path, srgb, TextureChannel::Colour);
    }

    /// A cut-out's opacity. It shares the colour texture's uv transform, so only a material
    /// without one may give the transform here.
    void read_opacity_texture(const JsonValue& value, Material& material, bool coloured) {
        const JsonObject object(
            value, coloured ? std::vector<std::string>{"file"}
                            : std::vector<std::string>{"file", "uv_matrix", "uv_offset",
                                                       "uv_rotate", "uv_scale"});
        const std::filesystem::path path = resolve(object.required("file"));
        if (!coloured) {
            material.uv_transform = read_uv_transform(object);
        }
        material.opacity_texture = texture_index(path, false, TextureChannel::Opacity);
    }

    /// Textures are numbered in order of first use, one per (file, srgb, channel).
    int texture_index(const std::filesystem::path& path, bool srgb, TextureChannel channel) {
        const auto key = std::tuple{path.string(), srgb, channel};
        auto it = m_texture_index.find(key);
        if (it == m_texture_index.end()) {
            it = m_texture_index.emplace(key, static_cast<int>(m_scene.textures.size())).first;
            m_scene.textures.push_back(Texture{path, srgb, channel});
        }
        return it->second;
    }

    void read_lights(const JsonValue& value) {
        for (const JsonValue& light : value.elements("an array of lights")) {
            const auto type = light.find("type");
            if (!type) {
                light.fail(R"(missing required key "type")");
            }
            if (type->choice({"ellipse", "point"}) == "point") {
                m_scene.point_lights.push_back(read_point_light(
                    JsonObject(light, {"intensity", "position", "power", "type"})));
            } else {
                m_scene.area_lights.push_back(read_ellipse_light(
                    JsonObject(light, {"center", "power", "radiance", "semi_axis_u", "semi_axis_v",
                                       "two_sided", "type"})));
            }
        }
    }

    PointLight read_point_light(const JsonObject& object) const {
        PointLight light;
        light.position = world_point(object.required("position"));
        const auto [value, is_intensity] = exactly_one_of(object, "intensity", "power");
        const Rgb colour = value.colour();
        // An isotropic source spreads its power over 4π steradians.
        light.intensity = is_intensity ? colour : Rgb(colour / (4.0f * kPi));
        return light;
    }

    EllipticalAreaLight read_ellipse_light(const JsonObject& object) const {
        EllipticalAreaLight light;
        light.center = world_point(object.required("center"));
        const JsonValue semi_axis_u = object.required("semi_axis_u");
        light.semi_axis_u = semi_axis_u.nonzero_vec3();
        const JsonValue semi_axis_v = object.required("semi_axis_v");
        light.semi_axis_v = semi_axis_v.nonzero_vec3();
        // The light's area and normal come from the cross product in single precision, whose
        // squared norm underflows below 1e-38: an axis whose own squared length does is
        // degenerate at any angle, whatever the other one.
        const Vec3d u = light.semi_axis_u.cast<double>();
        const Vec3d v = light.semi_axis_v.cast<double>();
        const double min_length = std::sqrt(static_cast<double>(std::numeric_limits<float>::min()));
        for (const auto& [axis, value] :
             {std::pair{&u, &semi_axis_u}, std::pair{&v, &semi_axis_v}}) {
            if (axis->norm() < min_length) {
                value->fail_expected(fmt::format(
                    "an axis at least {:.3g} long (its squared length underflows single "
                    "precision)",
                    min_length));
            }
        }
        // Parallel is a matter of angle, not size: the sine of the angle between the axes, from
        // unit vectors in double. Below 64 ε the single-precision cross product's rounding
        // (a few ε |u| |v|) leaves the normal's direction undetermined.
        const double sine = u.normalized().cross(v.normalized()).norm();
        if (!(sine > 64.0 * std::numeric_limits<float>::epsilon())) {
            semi_axis_v.fail_expected("a vector not parallel to semi_axis_u (non-zero area)");
        }
        const float area = light.area();
        if (!(area >= std::numeric_limits<float>::min()) || !std::isfinite(area)) {
            semi_axis_v.fail_expected(fmt::format(
                "axes whose area π |u| |v| sin θ (here {:.3g}) single precision can compute",
                std::numbers::pi * u.norm() * v.norm() * sine));
        }
        if (const auto two_sided = object.optional("two_sided")) {
            light.two_sided = two_sided->boolean();
        }
        const auto [value, is_radiance] = exactly_one_of(object, "radiance", "power");
        const Rgb colour = value.colour();
        // A Lambertian emitter of radiance L sends π·L·area watts out of each emitting face.
        const float faces = light.two_sided ? 2.0f : 1.0f;
        light.radiance = is_radiance ? colour : Rgb(colour / (kPi * area * faces));
        return light;
    }

    void read_groups(const std::optional<JsonValue>& groups, const JsonValue& objects) {
        m_scene.root = 0;
        m_scene.groups.push_back(Group{"world", {}});
        std::vector<std::pair<std::string, JsonValue>> named;
        if (groups) {
            named = groups->members("an object of named groups");
        }
        // Names first: a group may instance groups defined after it.
        for (const auto& entry : named) {
            m_group_index.emplace(entry.first, static_cast<std::uint32_t>(m_scene.groups.size()));
            m_scene.groups.push_back(Group{entry.first, {}});
        }
        m_group_references.resize(m_scene.groups.size());
        for (std::size_t i = 0; i < named.size(); ++i) {
            const JsonObject group(named[i].second, {"objects"});
            read_group_objects(static_cast<std::uint32_t>(i + 1), group.required("objects"));
        }
        read_group_objects(m_scene.root, objects);
    }

    void read_group_objects(std::uint32_t group, const JsonValue& objects) {
        for (const JsonValue& object : objects.elements("an array of objects")) {
            Instance instance = read_object(group, object);
            m_scene.groups[group].children.push_back(instance);
        }
    }

    Instance read_object(std::uint32_t group, const JsonValue& value) {
        Instance instance;
        if (const auto name_value = value.find("instance")) {
            const JsonObject object(value, {"instance", "transform"});
            const std::string name = name_value->string();
            const auto it = m_group_index.find(name);
            if (it == m_group_index.end()) {
                name_value->fail(fmt::format("unknown group \"{}\" ({})", name,
                                             expected_names(m_group_index, "groups")));
            }
            instance.kind = Instance::Kind::Group;
            instance.index = it->second;
            m_group_references[group].push_back(GroupReference{it->second, name_value->pointer()});
        } else {
            const auto shape = value.find("shape");
            if (!shape) {
                value.fail(R"(missing required key "shape" (or "instance"))");
            }
            instance.kind = Instance::Kind::Mesh;
            instance.index = read_shape(
                shape->choice({"checkerboard", "mesh", "plant", "quad", "sphere"}), value);
        }
        // The world's own objects are placed relative to the scene's origin; the children of
        // groups keep their object-local transforms.
        const auto transform = value.find("transform");
        if (transform || group == m_scene.root) {
            const Affine3d composed = transform ? read_transform(*transform) : Affine3d::Identity();
            instance.transform =
                single_precision_transform(transform ? *transform : value, composed,
                                           group == m_scene.root ? m_frame : WorldFrame());
        }
        return instance;
    }

    std::uint32_t read_shape(const std::string& shape, const JsonValue& value) {
        if (shape == "mesh") {
            const JsonObject object(value,
                                    {"crease_angle", "file", "material", "shape", "transform"});
            const JsonValue file = object.required("file");
            const auto crease_value = object.optional("crease_angle");
            const double crease_angle =
                crease_value
                    ? crease_value->number(NumberRange::closed(0.0, 180.0)) * kRadiansPerDegree
                    : kSmoothEverywhere;
            const auto material_value = object.optional("material");
            const std::optional<std::uint32_t> material =
                material_value ? std::optional(material_reference(*material_value)) : std::nullopt;
            return add_mesh_file(file, resolve(file), material, crease_angle);
        }
        if (shape == "sphere") {
            const JsonObject object(
                value, {"material", "radius", "rings", "segments", "shape", "transform"});
            const auto radius_value = object.optional("radius");
            const float radius =
                radius_value ? radius_value->number(NumberRange::above(0.0)) : 1.0f;
            const auto segments_value = object.optional("segments");
            const int segments = segments_value ? segments_value->integer(3, kMaxSegments) : 64;
            const auto rings_value = object.optional("rings");
            const int rings = rings_value ? rings_value->integer(2, kMaxSegments) : 32;
            const std::uint32_t material = material_reference(object.required("material"));
            return add_procedural(value,
                                  fmt::format("sphere radius={} segments={} rings={} material={}",
                                              radius, segments, rings, material),
                                  sphere_triangle_count(segments, rings),
                                  [=] { return make_sphere(radius, segments, rings, material); });
        }
        if (shape == "quad") {
            const JsonObject object(value, {"material", "shape", "size", "transform"});
            const Vec2f size = read_size(object);
            const std::uint32_t material = material_reference(object.required("material"));
            return add_procedural(
                value, fmt::format("quad size={}x{} material={}", size.x(), size.y(), material), 2,
                [=] { return make_quad(size.x(), size.y(), material); });
        }
        if (shape == "plant") {
            return read_plant(value);
        }
        const JsonObject object(value, {"materials", "shape", "size", "tiles", "transform"});
        const Vec2f size = read_size(object);
        int tiles_x = 8;
        int tiles_z = 8;
        if (const auto tiles = object.optional("tiles")) {
            const std::string expected = "an array of 2 integers (tiles along x, along z)";
            const auto counts = tiles->elements(expected);
            if (counts.size() != 2) {
                tiles->fail_expected(expected);
            }
            tiles_x = counts[0].integer(1, kMaxTiles);
            tiles_z = counts[1].integer(1, kMaxTiles);
        }
        const JsonValue materials = object.required("materials");
        const std::string expected = "an array of 2 material names";
        const auto names = materials.elements(expected);
        if (names.size() != 2) {
            materials.fail_expected(expected);
        }
        const std::uint32_t material_a = material_reference(names[0]);
        const std::uint32_t material_b = material_reference(names[1]);
        return add_procedural(
            value,
            fmt::format("checkerboard size={}x{} tiles={}x{} materials={},{}", size.x(), size.y(),
                        tiles_x, tiles_z, material_a, material_b),
            checkerboard_triangle_count(tiles_x, tiles_z), [=] {
                return make_checkerboard(size.x(), size.y(), tiles_x, tiles_z, material_a,
                                         material_b);
            });
    }

    std::uint32_t read_plant(const JsonValue& value) {
        const JsonObject object(value, {"depth", "leaf_material", "leaves_per_branch", "seed",
                                        "shape", "stem_material", "transform"});
        const auto seed_value = object.optional("seed");
        const int seed = seed_value ? seed_value->integer(0, kMaxPlantSeed) : 0;
        const auto depth_value = object.optional("depth");
        const int depth = depth_value ? depth_value->integer(0, kMaxPlantDepth) : 3;
        const auto leaves_value = object.optional("leaves_per_branch");
        const int leaves = leaves_value ? leaves_value->integer(0, kMaxPlantLeavesPerBranch) : 6;
        const std::uint32_t stem = material_reference(object.required("stem_material"));
        const std::uint32_t leaf = material_reference(object.required("leaf_material"));
        return add_procedural(value,
                              fmt::format("plant seed={} depth={} leaves={} materials={},{}", seed,
                                          depth, leaves, stem, leaf),
                              plant_triangle_count(depth, leaves), [=] {
                                  return make_plant(static_cast<std::uint64_t>(seed), depth, leaves,
                                                    stem, leaf);
                              });
    }

    static Vec2f read_size(const JsonObject& object) {
        const auto size = object.optional("size");
        return size ? size->vec2(NumberRange::above(0.0)) : Vec2f(1.0f, 1.0f);
    }

    std::uint32_t material_reference(const JsonValue& value) const {
        const std::string name = value.string();
        const auto it = m_material_index.find(name);
        if (it == m_material_index.end()) {
            value.fail(fmt::format("unknown material \"{}\" ({})", name,
                                   expected_names(m_material_index, "materials")));
        }
        return it->second;
    }

    std::filesystem::path resolve(const JsonValue& value) const {
        const std::string name = value.string();
        if (name.empty()) {
            value.fail_expected("a file name");
        }
        if (auto path = resolve_data_file(name, m_directory)) {
            return *path;
        }
        std::vector<std::string> looked;
        for (const auto& candidate : data_file_candidates(name, m_directory)) {
            looked.push_back(candidate.string());
        }
        value.fail(fmt::format("file \"{}\" not found (looked in: {})", name, join(looked, ", ")));
    }

    std::uint32_t add_mesh_file(const JsonValue& file, const std::filesystem::path& path,
                                std::optional<std::uint32_t> material, double crease_angle) {
        const auto key = std::tuple{path.string(), material, crease_angle};
        if (const auto it = m_file_meshes.find(key); it != m_file_meshes.end()) {
            return it->second;
        }
        const auto index = static_cast<std::uint32_t>(m_scene.meshes.size());
        m_scene.meshes.emplace_back();
        m_mesh_triangles.push_back(0);  // Known once the file is read.
        m_pending_files.push_back(
            PendingMeshFile{index, path, material, crease_angle, file.pointer()});
        m_file_meshes.emplace(key, index);
        return index;
    }

    /// A slot for the shape `make` generates, `triangles` of it, made by make_procedural_meshes
    /// once the whole scene is within its budgets.
    std::uint32_t add_procedural(const JsonValue& object, const std::string& recipe,
                                 std::uint64_t triangles, std::function<Mesh()> make) {
        if (const auto it = m_procedural_meshes.find(recipe); it != m_procedural_meshes.end()) {
            return it->second;
        }
        check_budget(m_options.budgets, "procedural-triangles", triangles,
                     "triangles in one procedural shape", m_file, object.pointer());
        const auto index = static_cast<std::uint32_t>(m_scene.meshes.size());
        m_scene.meshes.emplace_back();
        m_mesh_triangles.push_back(triangles);
        m_pending_procedural.push_back(PendingProcedural{index, object.pointer(), std::move(make)});
        m_procedural_meshes.emplace(recipe, index);
        return index;
    }

    void make_procedural_meshes() {
        for (PendingProcedural& pending : m_pending_procedural) {
            try {
                m_scene.meshes[pending.mesh] = pending.make();
            } catch (const Error& e) {
                // Each parameter is in range, but together they can exceed the vertex budget.
                throw Error(m_file, pending.pointer, e.what());
            }
        }
    }

    // Depth first with an explicit stack (a chain of a million groups must not overflow the
    // C++ one): the path is the stack's groups, and the edge followed out of stack[k] is the
    // reference just before its next one, so a back edge to stack[k] closes the cycle that
    // starts with that edge.
    void check_group_cycles() const {
        enum class VisitState : std::uint8_t { Unvisited, OnPath, Done };
        struct Frame {
            std::uint32_t group;
            std::size_t next_reference;
        };
        std::vector<VisitState> state(m_scene.groups.size(), VisitState::Unvisited);
        std::vector<Frame> stack;
        for (std::uint32_t start = 0; start < m_scene.groups.size(); ++start) {
            if (state[start] != VisitState::Unvisited) {
                continue;
            }
            state[start] = VisitState::OnPath;
            stack.push_back({start, 0});
            while (!stack.empty()) {
                Frame& frame = stack.back();
                const std::vector<GroupReference>& references = m_group_references[frame.group];
                if (frame.next_reference == references.size()) {
                    state[frame.group] = VisitState::Done;
                    stack.pop_back();
                    continue;
                }
                const GroupReference& reference = references[frame.next_reference++];
                if (state[reference.group] == VisitState::OnPath) {
                    throw_cycle(stack, reference.group);
                }
                if (state[reference.group] == VisitState::Unvisited) {
                    state[reference.group] = VisitState::OnPath;
                    stack.push_back({reference.group, 0});
                }
            }
        }
    }

    template <typename Frame>
    [[noreturn]] void throw_cycle(const std::vector<Frame>& stack, std::uint32_t closing) const {
        std::size_t start = 0;
        while (stack[start].group != closing) {
            ++start;
        }
        std::vector<std::string> names;
        for (std::size_t i = start; i < stack.size(); ++i) {
            names.push_back(m_scene.groups[stack[i].group].name);
        }
        names.push_back(m_scene.groups[closing].name);
        const GroupReference& first =
            m_group_references[stack[start].group][stack[start].next_reference - 1];
        throw Error(m_file, first.pointer, "group cycle " + join(names, " → "));
    }

    void load_mesh_files() {
        // A file used with several fallback materials is read once; the copies differ in
        // materials only.
        struct Loaded {
            MeshLoadResult result;
            std::vector<std::uint32_t> use_materials;  ///< Scene material of each `usemtl` name.
        };
        std::map<std::pair<std::filesystem::path, double>, Loaded> loaded;
        for (const PendingMeshFile& pending : m_pending_files) {
            const auto key = std::pair{pending.path, pending.crease_angle};
            auto it = loaded.find(key);
            if (it == loaded.end()) {
                Loaded file;
                try {
                    file.result = load_mesh(pending.path, 0, pending.crease_angle);
                    file.use_materials = file_materials(pending.path, file.result);
                } catch (const std::exception& e) {
                    throw Error(m_file, pending.pointer, e.what());
                }
                const std::size_t dropped = file.result.degenerate_triangles_removed;
                if (dropped > 0 && m_options.warn) {
                    m_options.warn(fmt::format(
                        "{}: {}: {}: dropped {} degenerate triangle{}", m_file.string(),
                        pending.pointer, pending.path.string(), dropped, dropped == 1 ? "" : "s"));
                }
                it = loaded.emplace(key, std::move(file)).first;
            }
            const Loaded& file = it->second;
            Mesh& slot = m_scene.meshes[pending.mesh];
            slot = file.result.mesh;
            const std::vector<std::uint32_t>& uses = file.result.triangle_material_uses;
            const bool any_without =
                uses.empty() || std::find(uses.begin(), uses.end(), kNoMaterialUse) != uses.end();
            const std::uint32_t fallback = !any_without       ? 0u
                                           : pending.material ? *pending.material
                                                              : default_material();
            for (std::size_t t = 0; t < slot.materials.size(); ++t) {
                const std::uint32_t use = uses.empty() ? kNoMaterialUse : uses[t];
                slot.materials[t] = use == kNoMaterialUse ? fallback : file.use_materials[use];
            }
        }
        for (const PendingMeshFile& pending : m_pending_files) {
            m_mesh_triangles[pending.mesh] = m_scene.meshes[pending.mesh].triangle_count();
        }
    }

    /// The scene material of each `usemtl` name of a loaded OBJ file, from its libraries.
    std::vector<std::uint32_t> file_materials(const std::filesystem::path& mesh_file,
                                              const MeshLoadResult& result) {
        std::vector<const MtlLibrary*> libraries;
        for (const MeshFileName& name : result.material_libraries) {
            const std::filesystem::path path = mesh_file.parent_path() / name.name;
            auto it = m_libraries.find(path);
            if (it == m_libraries.end()) {
                std::error_code error;
                if (!std::filesystem::is_regular_file(path, error)) {
                    throw Error(mesh_file, fmt::format("line {}", name.line),
                                fmt::format("material library '{}' not found (looked for {})",
                                            name.name, path.string()));
                }
                it = m_libraries.emplace(path, read_mtl(path, m_options.warn)).first;
            }
            libraries.push_back(&it->second);
        }
        std::vector<std::uint32_t> materials;
        for (const MeshFileName& use : result.material_uses) {
            const MtlLibrary* found_in = nullptr;
            const MtlMaterial* found = nullptr;
            for (const MtlLibrary* library : libraries) {
                if ((found = library->find(use.name)) != nullptr) {
                    found_in = library;
                    break;
                }
            }
            if (found == nullptr) {
                std::vector<std::string> names;
                for (const MeshFileName& library : result.material_libraries) {
                    names.push_back(library.name);
                }
                throw Error(mesh_file, fmt::format("line {}", use.line),
                            names.empty()
                                ? fmt::format("'usemtl {}' but the file names no material "
                                              "library ('mtllib')",
                                              use.name)
                                : fmt::format("material '{}' is in none of its libraries ({})",
                                              use.name, join(names, ", ")));
            }
            materials.push_back(mtl_material(*found_in, *found));
        }
        return materials;
    }

    /// The scene material of an MTL material, made once however many files use it.
    std::uint32_t mtl_material(const MtlLibrary& library, const MtlMaterial& mtl) {
        const auto key = std::pair{library.file, mtl.name};
        if (const auto it = m_mtl_materials.find(key); it != m_mtl_materials.end()) {
            return it->second;
        }
        const auto texture = [this](const std::filesystem::path& path, TextureChannel channel) {
            return texture_index(path, channel == TextureChannel::Colour, channel);
        };
        const std::string name =
            unique_material_name(library.file.filename().string() + ":" + mtl.name);
        const auto index =
            add_material(material_from_mtl(mtl, library.file, name, texture, m_options.warn));
        m_mtl_materials.emplace(key, index);
        return index;
    }

    /// Grey (the JSON material's defaults) for mesh faces given no material at all.
    std::uint32_t default_material() {
        if (!m_default_material) {
            Material m;
            m.name = unique_material_name("default");
            m_default_material = add_material(std::move(m));
        }
        return *m_default_material;
    }

    std::string unique_material_name(const std::string& base) const {
        std::string name = base;
        for (int n = 2; m_material_index.count(name) != 0; ++n) {
            name = fmt::format("{} ({})", base, n);
        }
        return name;
    }

    std::uint32_t add_material(Material material) {
        const auto index = static_cast<std::uint32_t>(m_scene.materials.size());
        m_material_index.emplace(material.name, index);
        m_scene.materials.push_back(std::move(material));
        return index;
    }

    const std::filesystem::path& m_file;
    std::filesystem::path m_directory;
    const SceneLoadOptions& m_options;
    Scene m_scene;
    WorldFrame m_frame;  ///< File world space → the scene's (camera-relative when far).
    std::map<std::string, std::uint32_t> m_material_index;
    std::map<std::string, std::uint32_t> m_group_index;
    std::map<std::tuple<std::string, bool, TextureChannel>, int> m_texture_index;
    std::map<std::tuple<std::string, std::optional<std::uint32_t>, double>, std::uint32_t>
        m_file_meshes;
    /// Material libraries read, by path, and the scene material of each (library, name) used.
    std::map<std::filesystem::path, MtlLibrary> m_libraries;
    std::map<std::pair<std::filesystem::path, std::string>, std::uint32_t> m_mtl_materials;
    std::optional<std::uint32_t> m_default_material;
    std::map<std::string, std::uint32_t> m_procedural_meshes;
    std::vector<PendingMeshFile> m_pending_files;
    std::vector<PendingProcedural> m_pending_procedural;
    /// Triangles of each slot of Scene::meshes, procedural ones counted before they are made.
    std::vector<std::uint64_t> m_mesh_triangles;
    std::vector<std::vector<GroupReference>> m_group_references;
};

}  // namespace

Scene load_scene(const std::filesystem::path& file, const SceneLoadOptions& options) {
    std::error_code error;
    if (std::filesystem::is_directory(file, error)) {
        throw Error(file, "", "is a directory, expected a scene file");
    }
    if (is_mesh_file(file)) {
        // A mesh file alone: the scene that frames it (docs/scene-format.md, "Looking at a
        // mesh").
        return parse_scene(mesh_view_scene(file).dump(2), file, options);
    }
    if (starts_like_section_file(file)) {
        Scene scene = scene_from_hierarchy(HierarchyFile::open(file), file, options.budgets);
        std::vector<std::uint64_t> mesh_triangles;
        mesh_triangles.reserve(scene.meshes.size());
        for (const Mesh& mesh : scene.meshes) {
            mesh_triangles.push_back(mesh.triangle_count());
        }
        // The same rules as for a scene file, so every tool and method sees one limit.
        check_expansion(
            scene, mesh_triangles, options.budgets,
            [&scene](std::uint32_t group) { return scene.groups[group].name; }, "");
        scene.mesh_lights = emissive_lights(scene);
        return scene;
    }
    return parse_scene(read_scene_text(file), file, options);
}

std::string read_scene_text(const std::filesystem::path& file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) {
        std::error_code error;
        throw Error(file, "",
                    std::filesystem::exists(file, error) ? "cannot read the scene file"
                                                         : "scene file not found");
    }
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) {
        throw Error(file, "", "cannot read the scene file");
    }
    return text.str();
}

Scene parse_scene(const std::string& json_text, const std::filesystem::path& file,
                  const SceneLoadOptions& options) {
    const Json document = parse_json_text(json_text, file);
    return SceneBuilder(file, options).build(document);
}

}  // namespace mrt
