#include "common/scene_io/scene_record.h"

#include "common/scene/scene_json.h"
#include "common/scene_io/scene_loader.h"
#include "common/system/error.h"

#include <fmt/format.h>

#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <numbers>
#include <set>
#include <string_view>
#include <tuple>
#include <utility>
#include <vector>

namespace mrt {

namespace {

// A field added to one of these types must be written below (and compared by
// tests/common/scene_io/scene_record_test.cpp) before the sizes are updated; otherwise records
// would lose it.
static_assert(sizeof(Camera) == 60, "write the new Camera field to the scene record");
static_assert(sizeof(PointLight) == 24, "write the new PointLight field to the scene record");
static_assert(sizeof(EllipticalAreaLight) == 52,
              "write the new EllipticalAreaLight field to the scene record");
static_assert(sizeof(Texture) == 48, "write the new Texture field to the scene record");
static_assert(sizeof(Material) == 136, "write the new Material field to the scene record");
// Scene::mesh_lights is not written: every loader derives it from the geometry's emissive faces.
static_assert(sizeof(Scene) == 328, "write the new Scene field to the scene record");

// The loader's conversion of "fov", which the written degrees must undo exactly.
constexpr double kRadiansPerDegree = std::numbers::pi / 180.0;

bool same_bits(float a, float b) {
    return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b);
}

/// The double to write for `x`: the shortest decimal that reads back as x, for a record that
/// people can read (and because the loader checks ranges on the double: 0.01f is below 0.01, the
/// decimal 0.01 is not). Else x itself, which a double holds exactly: when the loader's two
/// roundings (decimal → double → float) would turn the decimal into a neighbour of x, or when it
/// lies beyond the largest float (3.4028235e38 does), which the loader refuses.
double record_number(float x) {
    char text[32];
    const char* end = std::to_chars(std::begin(text), std::end(text), x).ptr;
    double shortest = 0.0;
    std::from_chars(text, end, shortest);
    const bool in_range =
        std::abs(shortest) <= static_cast<double>(std::numeric_limits<float>::max());
    return in_range && same_bits(static_cast<float>(shortest), x) ? shortest
                                                                  : static_cast<double>(x);
}

/// Writes the record of one scene; every failure names the JSON pointer the value would have had.
class RecordWriter {
  public:
    explicit RecordWriter(const Scene& scene) : m_scene(scene) {}

    Json write() const {
        Json record = Json::object();
        record["camera"] = camera();
        record["background"] = colour(m_scene.background, "/background");
        record["ambient"] = colour(m_scene.ambient, "/ambient");
        record["max_depth"] = m_scene.max_depth;
        record["materials"] = materials();
        record["lights"] = lights();
        // Always written: a record's camera and lights, and the geometry of its hierarchy file,
        // are relative to it, so the loader must keep them as they are (a file without
        // "world_origin" may be re-based on its eye).
        record["world_origin"] = world_origin();
        // The one required key of the geometry, empty: a scene file may have no objects.
        record["objects"] = Json::array();
        return record;
    }

  private:
    [[noreturn]] void fail(const std::string& pointer, const std::string& message) const {
        const std::filesystem::path file =
            m_scene.file.empty() ? std::filesystem::path("(scene)") : m_scene.file;
        throw Error(file, pointer, "cannot be written to a scene record: " + message);
    }

    double number(float x, const std::string& pointer) const {
        if (!std::isfinite(x)) {
            fail(pointer, fmt::format("found {}, expected a finite number", x));
        }
        return record_number(x);
    }

    template <typename Vector>
    Json numbers(const Vector& v, const std::string& pointer) const {
        Json array = Json::array();
        for (Eigen::Index i = 0; i < v.size(); ++i) {
            array.push_back(number(v[i], fmt::format("{}/{}", pointer, i)));
        }
        return array;
    }

    Json vec3(const Vec3f& v, const std::string& pointer) const { return numbers(v, pointer); }
    Json colour(const Rgb& c, const std::string& pointer) const { return numbers(c, pointer); }

    /// The degrees the loader turns back into `radians`: preferably the short decimal of the
    /// nearest float; else the double quotient, whose product with π/180 is within a few double
    /// ulps of the float radians and so rounds back to them.
    double fov_degrees(float radians) const {
        const std::string pointer = "/camera/fov";
        number(radians, pointer);  // Rejects a non-finite angle.
        const double exact = static_cast<double>(radians) / kRadiansPerDegree;
        for (const double degrees : {record_number(static_cast<float>(exact)), exact}) {
            if (same_bits(static_cast<float>(degrees * kRadiansPerDegree), radians)) {
                return degrees;
            }
        }
        fail(pointer,
             fmt::format("found vertical_fov {} rad, which no number of degrees gives back",
                         radians));
    }

    Json camera() const {
        const Camera& c = m_scene.camera;
        Json out = Json::object();
        out["eye"] = vec3(c.eye, "/camera/eye");
        out["look_at"] = vec3(c.look_at, "/camera/look_at");
        out["up"] = vec3(c.up, "/camera/up");
        out["fov"] = fov_degrees(c.vertical_fov);
        out["resolution"] = Json::array({c.width, c.height});
        out["aperture_radius"] = number(c.aperture_radius, "/camera/aperture_radius");
        // 0 (Camera's default) means "focus on look_at" to CameraRays; the loader, which wants a
        // positive distance, makes it that distance when the key is left out.
        if (c.focal_distance != 0.0f) {
            out["focal_distance"] = number(c.focal_distance, "/camera/focal_distance");
        }
        out["pixel_aspect"] = number(c.pixel_aspect, "/camera/pixel_aspect");
        return out;
    }

    Json world_origin() const {
        const Vec3d& origin = m_scene.world_origin;
        Json out = Json::array();
        for (Eigen::Index i = 0; i < 3; ++i) {
            // Doubles are written with the digits that read back as the same double; the loader
            // accepts magnitudes up to the largest float.
            if (!std::isfinite(origin[i]) ||
                std::abs(origin[i]) > static_cast<double>(std::numeric_limits<float>::max())) {
                fail(fmt::format("/world_origin/{}", i),
                     fmt::format("found {}, expected a finite number of magnitude <= 3.4e38",
                                 origin[i]));
            }
            out.push_back(origin[i]);
        }
        return out;
    }

    Json materials() const {
        check_textures();
        Json out = Json::object();
        for (const Material& m : m_scene.materials) {
            const std::string pointer = "/materials/" + pointer_token(m.name);
            if (out.contains(m.name)) {
                fail(pointer, "a second material of this name, expected unique names");
            }
            Json material = Json::object();
            material["diffuse"] = colour(m.diffuse, pointer + "/diffuse");
            material["specular"] = colour(m.specular, pointer + "/specular");
            material["phong_exponent"] = number(m.phong_exponent, pointer + "/phong_exponent");
            material["reflectivity"] = number(m.reflectivity, pointer + "/reflectivity");
            material["transparency"] = number(m.transparency, pointer + "/transparency");
            material["ior"] = number(m.ior, pointer + "/ior");
            material["roughness"] = number(m.roughness, pointer + "/roughness");
            if (m.emits()) {
                material["emission"] = colour(m.emission, pointer + "/emission");
            }
            if (m.texture >= 0) {
                material["texture"] = texture(m, pointer + "/texture");
            }
            if (m.cut_out()) {
                material["opacity_texture"] = opacity_texture(m, pointer + "/opacity_texture");
            }
            out[m.name] = std::move(material);
        }
        return out;
    }

    Json texture(const Material& m, const std::string& pointer) const {
        const Texture& t = m_scene.textures[static_cast<std::size_t>(m.texture)];
        Json out = Json::object();
        out["file"] = t.path.string();
        out["srgb"] = t.srgb;
        out["uv_matrix"] = uv_matrix(m, pointer + "/uv_matrix");
        return out;
    }

    /// The loader reads the uv transform from the opacity texture only without a colour one.
    Json opacity_texture(const Material& m, const std::string& pointer) const {
        Json out = Json::object();
        out["file"] = m_scene.textures[static_cast<std::size_t>(m.opacity_texture)].path.string();
        if (m.texture < 0) {
            out["uv_matrix"] = uv_matrix(m, pointer + "/uv_matrix");
        }
        return out;
    }

    Json uv_matrix(const Material& m, const std::string& matrix) const {
        const Mat2f linear = m.uv_transform.linear();
        const Vec2f offset = m.uv_transform.translation();
        return Json::array(
            {number(linear(0, 0), matrix + "/0"), number(linear(0, 1), matrix + "/1"),
             number(offset(0), matrix + "/2"), number(linear(1, 0), matrix + "/3"),
             number(linear(1, 1), matrix + "/4"), number(offset(1), matrix + "/5"), 0.0, 0.0, 1.0});
    }

    // Textures live inside materials in a scene file, so the loader rebuilds Scene::textures
    // from them: one entry per (path, srgb, channel), numbered in order of first use (a
    // material's colour texture before its opacity). Any other table would come back
    // renumbered (or without its unused entries).
    void check_textures() const {
        std::set<std::tuple<std::string, bool, TextureChannel>> distinct;
        for (std::size_t i = 0; i < m_scene.textures.size(); ++i) {
            const Texture& t = m_scene.textures[i];
            const std::string where = fmt::format("texture {} \"{}\"", i, t.path.string());
            if (!t.path.is_absolute() || t.path != t.path.lexically_normal()) {
                fail("", where + ": expected an absolute, normal path (as the loader resolves)");
            }
            if (t.channel != TextureChannel::Colour && t.channel != TextureChannel::Opacity) {
                fail("", where + ": an unknown channel, expected colour or opacity");
            }
            if (t.channel == TextureChannel::Opacity && t.srgb) {
                fail("", where + ": an sRGB opacity, expected opacities read as stored");
            }
            if (!distinct.emplace(t.path.string(), t.srgb, t.channel).second) {
                fail("", where +
                             ": a second texture of this path, srgb flag and channel, "
                             "expected one");
            }
        }
        std::vector<bool> used(m_scene.textures.size(), false);
        std::size_t first_uses = 0;
        const auto use = [&](int texture, TextureChannel channel, const std::string& pointer) {
            const auto index = static_cast<std::size_t>(texture);
            if (texture < 0 || index >= m_scene.textures.size()) {
                fail(pointer, fmt::format("found texture index {}, expected -1 or an index into "
                                          "the {} textures",
                                          texture, m_scene.textures.size()));
            }
            if (m_scene.textures[index].channel != channel) {
                fail(pointer, fmt::format("texture {} is read as {}, expected {}", index,
                                          channel_name(m_scene.textures[index].channel),
                                          channel_name(channel)));
            }
            if (!used[index]) {
                if (index != first_uses) {
                    fail(pointer, fmt::format("texture {} is used before texture {}, expected "
                                              "textures numbered in order of first use",
                                              index, first_uses));
                }
                used[index] = true;
                ++first_uses;
            }
        };
        for (const Material& m : m_scene.materials) {
            const std::string pointer = "/materials/" + pointer_token(m.name);
            if (m.texture != -1) {
                use(m.texture, TextureChannel::Colour, pointer + "/texture");
            }
            if (m.opacity_texture != -1) {
                use(m.opacity_texture, TextureChannel::Opacity, pointer + "/opacity_texture");
            }
            if (m.texture == -1 && m.opacity_texture == -1 &&
                m.uv_transform.matrix() != Mat3f::Identity()) {
                fail(pointer + "/texture",
                     "found a uv transform without a texture, expected the identity");
            }
        }
        if (first_uses != m_scene.textures.size()) {
            fail("", fmt::format("texture {} is used by no material, expected every texture used",
                                 first_uses));
        }
    }

    static const char* channel_name(TextureChannel channel) {
        return channel == TextureChannel::Opacity ? "an opacity" : "a colour";
    }

    Json lights() const {
        Json out = Json::array();
        for (const PointLight& light : m_scene.point_lights) {
            const std::string pointer = fmt::format("/lights/{}", out.size());
            Json point = Json::object();
            point["type"] = "point";
            point["position"] = vec3(light.position, pointer + "/position");
            point["intensity"] = colour(light.intensity, pointer + "/intensity");
            out.push_back(std::move(point));
        }
        for (const EllipticalAreaLight& light : m_scene.area_lights) {
            const std::string pointer = fmt::format("/lights/{}", out.size());
            Json ellipse = Json::object();
            ellipse["type"] = "ellipse";
            ellipse["center"] = vec3(light.center, pointer + "/center");
            ellipse["semi_axis_u"] = vec3(light.semi_axis_u, pointer + "/semi_axis_u");
            ellipse["semi_axis_v"] = vec3(light.semi_axis_v, pointer + "/semi_axis_v");
            ellipse["radiance"] = colour(light.radiance, pointer + "/radiance");
            ellipse["two_sided"] = light.two_sided;
            out.push_back(std::move(ellipse));
        }
        return out;
    }

    const Scene& m_scene;
};

}  // namespace

std::string scene_record_json(const Scene& scene) {
    const Json record = RecordWriter(scene).write();
    try {
        return record.dump();
    } catch (const Json::type_error& e) {
        // JSON text is UTF-8; a material name or a path may hold other bytes.
        throw Error(scene.file.empty() ? std::filesystem::path("(scene)") : scene.file, "",
                    fmt::format("cannot be written to a scene record: a material name or texture "
                                "path is not UTF-8 ({})",
                                e.what()));
    }
}

Scene load_scene_record(const std::string& json_text, const std::filesystem::path& file,
                        const Budgets& budgets) {
    // Checked before the loader runs, which would otherwise read the mesh files it names.
    const Json document = parse_json_text(json_text, file);
    if (document.is_object()) {
        const JsonValue root(file, document, "");
        if (const auto groups = root.find("groups")) {
            groups->fail_expected("no \"groups\" (a scene record holds no geometry)");
        }
        const auto objects = root.find("objects");
        if (objects && objects->json().is_array() && !objects->json().empty()) {
            objects->fail_expected("[] (a scene record holds no geometry)");
        }
    }
    SceneLoadOptions options;
    options.budgets = budgets;
    return parse_scene(json_text, file, options);
}

}  // namespace mrt
