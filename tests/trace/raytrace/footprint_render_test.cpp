// Ray differentials (Igehy 1999) as the tracer actually propagates them: a camera ray followed
// hit by hit through the library's own components — SceneBvh::intersect, make_surface_point,
// make_surface_differential and RayDifferential::transfer / reflect / refract, chained as
// RayTree::radiance chains them — against one-sided finite differences of offset rays traced
// the same way. And full renders of stiff cases (grazing incidence, silhouettes, the critical
// angle, degenerate triangles, a scene far from the origin) that must stay finite and bounded.

#include "common/footprint/footprint.h"
#include "common/image/image.h"
#include "common/scene_io/scene_loader.h"
#include "common/texture/texture.h"
#include "tests/support/test_support.h"
#include "trace/bvh/scene_bvh.h"
#include "trace/raytrace/distributed.h"
#include "trace/raytrace/ray_tree.h"
#include "trace/raytrace/surface_point.h"
#include "trace/raytrace/whitted.h"
#include "trace/render/camera_rays.h"
#include "trace/render/shading.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

namespace mrt {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// ---------------------------------------------------------------------------------------------
// The traced path and its differentials.

/// What happens at one hit of a traced path.
enum class Event {
    Stop,     ///< Transfer the differential to the hit and end there.
    Reflect,  ///< Mirror about the shading normal (the geometric one where that points inside).
    Refract,  ///< Refract through the shading normal, or mirror under total internal reflection.
};

/// One hit of a path: where, which way the path leaves it, and the differentials of both.
struct PathVertex {
    Vec3f position = Vec3f::Zero();   ///< World hit point.
    Vec3f direction = Vec3f::Zero();  ///< Unit direction leaving the hit (incoming at a Stop).
    Vec2f uv = Vec2f::Zero();         ///< Mesh texture coordinates at the hit.
    bool has_uv = false;
    /// dp_* of the hit point, dd_* of `direction`.
    RayDifferential differential;
    Vec2f duv_dx = Vec2f::Zero();  ///< Texture-coordinate derivatives at the hit.
    Vec2f duv_dy = Vec2f::Zero();
    float distance = 0.0f;                 ///< Path length from the camera to the hit.
    Vec3f normal = Vec3f::Zero();          ///< Unit geometric normal, facing the arriving ray.
    Vec3f shading_normal = Vec3f::Zero();  ///< Unit interpolated normal, on the same side.
    float cos_incidence = 0.0f;            ///< |d·n_geometric| of the arriving ray.
    std::uint32_t material = 0;
    std::uint32_t mesh = 0;
    std::uint32_t triangle = 0;
    /// The direction did not come from the smooth branch: a mirror about the geometric normal,
    /// a mirror under total internal reflection, or a direction folded back to its side.
    bool fallback = false;
};

/// Follows the camera ray through raster (x, y) for at most events.size() hits, exactly as
/// RayTree::radiance propagates a footprint down one deterministic branch (CentreSampling: no
/// spread). Ends early when the ray leaves the scene.
std::vector<PathVertex> trace_path(const Scene& scene, const SceneBvh& bvh,
                                   const CameraRays& camera, float x, float y,
                                   const std::vector<Event>& events) {
    Ray ray = camera.pinhole_ray(x, y);
    RayDifferential differential = camera.pinhole_differential(x, y);
    float travelled = 0.0f;
    std::vector<PathVertex> path;
    for (const Event event : events) {
        SceneHit hit;
        if (!bvh.intersect(ray, hit)) {
            break;
        }
        const Vec3f d = ray.direction.normalized();
        const SurfacePoint sp = make_surface_point(scene, hit, d);
        const float t = hit.t * ray.direction.norm();
        travelled += t;
        const RayDifferential at_hit = differential.transfer(d, t, sp.geometric_normal);
        const SurfaceDifferential surface =
            make_surface_differential(scene, hit, sp, at_hit.dp_dx, at_hit.dp_dy);

        PathVertex v;
        v.position = sp.position;
        v.uv = sp.uv;
        v.has_uv = sp.has_uv;
        v.duv_dx = surface.duv_dx;
        v.duv_dy = surface.duv_dy;
        v.distance = travelled;
        v.normal = sp.geometric_normal;
        v.shading_normal = sp.shading_normal;
        v.cos_incidence = std::abs(d.dot(sp.geometric_normal));
        v.material = sp.material;
        v.mesh = hit.mesh;
        v.triangle = hit.triangle;
        v.direction = d;
        v.differential = at_hit;

        bool mirror = event == Event::Reflect;
        if (event == Event::Refract) {
            const float ior = scene.materials[sp.material].ior;
            const float eta = sp.entering ? 1.0f / ior : ior;
            if (const auto refracted = refract(d, sp.shading_normal, eta)) {
                v.direction = fold_to_side(*refracted, sp.geometric_normal, Side::Below);
                v.fallback = v.direction != *refracted;
                v.differential =
                    at_hit.refract(d, sp.shading_normal, surface.dn_dx, surface.dn_dy, eta);
            } else {
                mirror = true;
                v.fallback = true;
            }
        }
        if (mirror) {
            const Mirror m = mirror_at(d, sp, surface);
            const Vec3f& r = m.direction;
            v.fallback = v.fallback || m.about_geometric;
            v.direction = fold_to_side(r, sp.geometric_normal, Side::Above);
            v.fallback = v.fallback || v.direction != r;
            v.differential = at_hit.reflect(d, m.normal, m.dn_dx, m.dn_dy);
        }
        path.push_back(v);
        if (event == Event::Stop) {
            break;
        }
        ray = Ray{sp.spawn_origin(v.direction), v.direction, kInfinity};
        differential = v.differential;
    }
    return path;
}

// ---------------------------------------------------------------------------------------------
// Finite differences.

/// The raster offsets of the forward differences, in pixels.
constexpr float kOffsets[] = {1.0f / 4.0f, 1.0f / 8.0f, 1.0f / 16.0f, 1.0f / 32.0f};
constexpr int kOffsetCount = 4;

/// Offset paths that cross into another triangle (or another object, or switch branch) see a
/// different smooth piece of the scene, where no derivative at (x, y) describes them.
bool same_smooth_piece(const std::vector<PathVertex>& a, const std::vector<PathVertex>& b) {
    if (a.size() != b.size()) {
        return false;
    }
    for (std::size_t i = 0; i < a.size(); ++i) {
        if (a[i].mesh != b[i].mesh || a[i].triangle != b[i].triangle ||
            a[i].material != b[i].material || a[i].fallback != b[i].fallback) {
            return false;
        }
    }
    return true;
}

/// One quantity of one vertex differentiated along one raster axis, at every offset.
struct Convergence {
    std::string what;
    double derivative = 0.0;          ///< |differential|.
    double error[kOffsetCount] = {};  ///< |forward difference − differential| / |differential|.
    double noise[kOffsetCount] = {};  ///< Relative rounding noise measured at each offset.
    /// Relative error of the Richardson extrapolation 2·FD(1/32) − FD(1/16), second order.
    double richardson = 0.0;
};

std::ostream& operator<<(std::ostream& os, const Convergence& c) {
    os << c.what << " |D|=" << c.derivative << " err";
    for (int k = 0; k < kOffsetCount; ++k) {
        os << ' ' << c.error[k];
    }
    os << " noise";
    for (int k = 0; k < kOffsetCount; ++k) {
        os << ' ' << c.noise[k];
    }
    return os << " richardson " << c.richardson;
}

/// The differentiated quantities of a vertex, in double: hit position, leaving direction, uv.
struct VertexValues {
    Vec3d position;
    Vec3d direction;
    Vec2d uv;
};

VertexValues values(const PathVertex& v) {
    return {v.position.cast<double>(), v.direction.cast<double>(), v.uv.cast<double>()};
}

/// The differential of each quantity of `v` along `axis`, in double.
VertexValues derivatives(const PathVertex& v, int axis) {
    const RayDifferential& rd = v.differential;
    return {(axis == 0 ? rd.dp_dx : rd.dp_dy).cast<double>(),
            (axis == 0 ? rd.dd_dx : rd.dd_dy).cast<double>(),
            (axis == 0 ? v.duv_dx : v.duv_dy).cast<double>()};
}

/// Raster offsets so small that the truncation error of a forward difference is far below
/// rounding (second order in them): what is left of |f(x+δ) − f(x) − δ·D| is the rounding
/// noise of the traced values, measured rather than modelled, since it grows with each
/// bounce. Multiples of 2⁻¹¹, exact in float next to any raster coordinate below 2¹².
constexpr int kNoiseProbes = 8;
constexpr float kNoiseStep = 1.0f / 2048.0f;

/// The path at (x, y) and its finite-difference convergence for every vertex, quantity (hit
/// position, leaving direction, texture coordinates) and axis; empty when an offset path
/// leaves the smooth piece of the base path.
std::vector<Convergence> convergence_at(const Scene& scene, const SceneBvh& bvh,
                                        const CameraRays& camera, float x, float y,
                                        const std::vector<Event>& events) {
    const std::vector<PathVertex> base = trace_path(scene, bvh, camera, x, y, events);
    if (base.size() != events.size()) {
        return {};
    }
    const auto offset_path = [&](int axis, float h) {
        return trace_path(scene, bvh, camera, axis == 0 ? x + h : x, axis == 1 ? y + h : y, events);
    };
    std::vector<std::vector<PathVertex>> offset[2];
    std::vector<std::vector<PathVertex>> probe[2];
    for (int axis = 0; axis < 2; ++axis) {
        for (const float h : kOffsets) {
            offset[axis].push_back(offset_path(axis, h));
            if (!same_smooth_piece(base, offset[axis].back())) {
                return {};
            }
        }
        for (int k = 1; k <= kNoiseProbes; ++k) {
            probe[axis].push_back(offset_path(axis, static_cast<float>(k) * kNoiseStep));
            if (!same_smooth_piece(base, probe[axis].back())) {
                return {};
            }
        }
    }

    std::vector<Convergence> result;
    for (std::size_t i = 0; i < base.size(); ++i) {
        const VertexValues f = values(base[i]);
        for (int axis = 0; axis < 2; ++axis) {
            const VertexValues d = derivatives(base[i], axis);
            // Absolute rounding noise of each quantity's difference f(x+δ) − f(x).
            double noise_p = 0.0, noise_d = 0.0, noise_uv = 0.0;
            for (int k = 1; k <= kNoiseProbes; ++k) {
                const double delta = k * static_cast<double>(kNoiseStep);
                const VertexValues g = values(probe[axis][static_cast<std::size_t>(k - 1)][i]);
                noise_p = std::max(noise_p, (g.position - f.position - delta * d.position).norm());
                noise_d =
                    std::max(noise_d, (g.direction - f.direction - delta * d.direction).norm());
                noise_uv = std::max(noise_uv, (g.uv - f.uv - delta * d.uv).norm());
            }
            const std::string prefix = "vertex " + std::to_string(i) + " ";
            const std::string suffix = axis == 0 ? " d/dx" : " d/dy";
            Convergence position{prefix + "position" + suffix, d.position.norm()};
            Convergence direction{prefix + "direction" + suffix, d.direction.norm()};
            Convergence uv{prefix + "uv" + suffix, d.uv.norm()};
            VertexValues fd[kOffsetCount];
            for (int k = 0; k < kOffsetCount; ++k) {
                const double h = kOffsets[k];
                const VertexValues g = values(offset[axis][static_cast<std::size_t>(k)][i]);
                fd[k] = {(g.position - f.position) / h, (g.direction - f.direction) / h,
                         (g.uv - f.uv) / h};
                position.error[k] = (fd[k].position - d.position).norm() / position.derivative;
                direction.error[k] = (fd[k].direction - d.direction).norm() / direction.derivative;
                uv.error[k] = (fd[k].uv - d.uv).norm() / uv.derivative;
                position.noise[k] = noise_p / (h * position.derivative);
                direction.noise[k] = noise_d / (h * direction.derivative);
                uv.noise[k] = noise_uv / (h * uv.derivative);
            }
            const int last = kOffsetCount - 1;
            position.richardson =
                (2.0 * fd[last].position - fd[last - 1].position - d.position).norm() /
                position.derivative;
            direction.richardson =
                (2.0 * fd[last].direction - fd[last - 1].direction - d.direction).norm() /
                direction.derivative;
            uv.richardson = (2.0 * fd[last].uv - fd[last - 1].uv - d.uv).norm() / uv.derivative;
            result.push_back(position);
            result.push_back(direction);
            if (base[i].has_uv && uv.derivative > 0.0) {
                result.push_back(uv);
            }
        }
    }
    return result;
}

/// A raster position whose path completes its events with every offset path on the same
/// smooth piece, and the convergence of its differentials.
struct Sample {
    float x = 0.0f;
    float y = 0.0f;
    std::vector<Convergence> convergence;
};

/// Up to `count` samples inside [x0, x1] × [y0, y1], tried along the R2 low-discrepancy
/// sequence (spread over the region, deterministic) and snapped to a 1/8-pixel grid so that
/// every x + h is exact in float.
std::vector<Sample> find_samples(const Scene& scene, const SceneBvh& bvh, const CameraRays& camera,
                                 const std::vector<Event>& events, float x0, float x1, float y0,
                                 float y1, int count) {
    std::vector<Sample> samples;
    const auto snap = [](double v) { return static_cast<float>(std::round(v * 8.0) / 8.0); };
    for (int n = 0; n < 64 && static_cast<int>(samples.size()) < count; ++n) {
        const double u = std::fmod(0.5 + n * 0.7548776662466927, 1.0);
        const double v = std::fmod(0.5 + n * 0.5698402909980532, 1.0);
        const float x = snap(x0 + u * (x1 - x0));
        const float y = snap(y0 + v * (y1 - y0));
        std::vector<Convergence> c = convergence_at(scene, bvh, camera, x, y, events);
        if (!c.empty()) {
            samples.push_back({x, y, std::move(c)});
        }
    }
    return samples;
}

/// What the convergence checks of a case found, over all its samples.
struct ConvergenceSummary {
    int quantities = 0;
    int ratios_checked = 0;    ///< Error ratios above the noise, so checked.
    double worst_error = 0.0;  ///< Largest relative error of a forward difference at h = 1/32.
    double worst_richardson = 0.0;
    double min_ratio = std::numeric_limits<double>::infinity();
    double max_ratio = 0.0;
};

/// Relative error allowed to a forward difference at 1/32 pixel. It is the first-order
/// truncation term, proportional to the pixel's angular size, which the cases make large
/// (0.03–0.05 rad) so that truncation stays far above rounding; measured up to 3.2e-2.
constexpr double kForwardTolerance = 5e-2;
/// Relative error allowed to the Richardson extrapolation 2·FD(1/32) − FD(1/16), accurate to
/// second order, beyond its own rounding noise (2.5 times that of FD(1/32)); measured at most
/// 6.3e-4 above that noise allowance (6.0e-3 in all).
constexpr double kRichardsonTolerance = 5e-3;
/// Error ratios are checked only while both errors are this many times their rounding noise.
constexpr double kAboveNoise = 4.0;

/// The properties of a converging forward difference: at the smallest offset it is close to
/// the differential and its Richardson extrapolation closer still, and while its error is well
/// above rounding noise the error halves with the offset (first-order convergence: the
/// differential is the limit of the differences, not merely near them).
ConvergenceSummary expect_linear_convergence(const std::vector<Sample>& samples) {
    ConvergenceSummary summary;
    for (const Sample& s : samples) {
        for (const Convergence& c : s.convergence) {
            ++summary.quantities;
            SCOPED_TRACE(::testing::Message() << "raster (" << s.x << ", " << s.y << ") " << c);
            EXPECT_TRUE(std::isfinite(c.derivative) && c.derivative > 0.0);
            const int last = kOffsetCount - 1;
            EXPECT_LE(c.error[last], kForwardTolerance);
            EXPECT_LE(c.richardson, kRichardsonTolerance + 2.5 * c.noise[last]);
            summary.worst_error = std::max(summary.worst_error, c.error[last]);
            summary.worst_richardson = std::max(summary.worst_richardson, c.richardson);
            for (int k = 0; k < last; ++k) {
                if (c.error[k + 1] < kAboveNoise * c.noise[k + 1]) {
                    break;
                }
                const double ratio = c.error[k] / c.error[k + 1];
                ++summary.ratios_checked;
                summary.min_ratio = std::min(summary.min_ratio, ratio);
                summary.max_ratio = std::max(summary.max_ratio, ratio);
                EXPECT_GE(ratio, 1.5) << "offsets " << kOffsets[k] << " → " << kOffsets[k + 1];
                EXPECT_LE(ratio, 2.6) << "offsets " << kOffsets[k] << " → " << kOffsets[k + 1];
            }
        }
    }
    return summary;
}

// ---------------------------------------------------------------------------------------------
// Scenes.

/// A 64×64 linear checker of 8×8-texel tiles (uv [0,1]² holds 8×8 tiles).
void write_checker(const fs::path& file) {
    Image checker(64, 64);
    for (int y = 0; y < 64; ++y) {
        for (int x = 0; x < 64; ++x) {
            checker.set(x, y,
                        ((x / 8 + y / 8) % 2 == 0) ? Rgb(0.9f, 0.9f, 0.9f) : Rgb(0.1f, 0.1f, 0.1f));
        }
    }
    write_image(file, checker);
}

json camera_json(const Vec3f& eye, const Vec3f& look_at, float fov_degrees, int width, int height,
                 const Vec3f& up = Vec3f::UnitY(), float pixel_aspect = 1.0f) {
    return {
        {"eye", {eye.x(), eye.y(), eye.z()}}, {"look_at", {look_at.x(), look_at.y(), look_at.z()}},
        {"up", {up.x(), up.y(), up.z()}},     {"fov", fov_degrees},
        {"resolution", {width, height}},      {"pixel_aspect", pixel_aspect}};
}

/// Materials every scene shares: a textured diffuse floor, a mirror, glass (pure refraction
/// and a little reflection) and no specular highlights, so that radiance is bounded by the
/// ambient and the lights' direct irradiance (see radiance_bound).
json materials_json() {
    return {
        {"floor",
         {{"diffuse", 1},
          {"texture", {{"file", "checker.exr"}, {"srgb", false}, {"uv_scale", 8}}}}},
        {"mirror", {{"diffuse", 0.1}, {"reflectivity", 0.9}}},
        {"glass", {{"diffuse", 0}, {"reflectivity", 0.05}, {"transparency", 0.95}, {"ior", 1.5}}},
        {"textured_mirror",
         {{"diffuse", 1},
          {"reflectivity", 0.5},
          {"texture", {{"file", "checker.exr"}, {"srgb", false}, {"uv_scale", 3}}}}},
    };
}

json quad(float size, const Vec3f& translate, const std::string& material = "floor") {
    return {{"shape", "quad"},
            {"size", {size, size}},
            {"material", material},
            {"transform", {{"translate", {translate.x(), translate.y(), translate.z()}}}}};
}

json sphere(float radius, const Vec3f& centre, const std::string& material, int segments = 64,
            int rings = 32) {
    return {{"shape", "sphere"},
            {"radius", radius},
            {"segments", segments},
            {"rings", rings},
            {"material", material},
            {"transform", {{"translate", {centre.x(), centre.y(), centre.z()}}}}};
}

json point_light(const Vec3f& position, float intensity) {
    return {{"type", "point"},
            {"position", {position.x(), position.y(), position.z()}},
            {"intensity", intensity}};
}

/// Writes the scene into `dir` (with the checker it refers to) and loads it.
Scene load_json_scene(const fs::path& dir, const json& scene_json,
                      const std::string& name = "scene.json") {
    if (!fs::exists(dir / "checker.exr")) {
        write_checker(dir / "checker.exr");
    }
    std::ofstream(dir / name) << scene_json.dump(2);
    return load_scene(dir / name);
}

json base_scene(const json& camera) {
    return {{"camera", camera},
            {"background", 0.2},
            {"ambient", 0.3},
            {"max_depth", 6},
            {"materials", materials_json()},
            {"lights", json::array()},
            {"objects", json::array()}};
}

/// Writes a UV sphere OBJ of unit radius with exact sphere normals and (longitude, latitude)
/// uvs: a coarse normal-interpolated mesh whose shading normals differ visibly from its faces.
void write_uv_sphere_obj(const fs::path& file, int segments, int rings) {
    std::ofstream out(file);
    out << std::setprecision(9);
    for (int r = 0; r <= rings; ++r) {
        const double theta = std::numbers::pi * r / rings;
        for (int s = 0; s <= segments; ++s) {
            const double phi = 2.0 * std::numbers::pi * s / segments;
            const double px = std::sin(theta) * std::cos(phi);
            const double py = std::cos(theta);
            const double pz = -std::sin(theta) * std::sin(phi);
            out << "v " << px << ' ' << py << ' ' << pz << '\n';
            out << "vn " << px << ' ' << py << ' ' << pz << '\n';
            out << "vt " << static_cast<double>(s) / segments << ' '
                << 1.0 - static_cast<double>(r) / rings << '\n';
        }
    }
    const auto index = [&](int r, int s) { return r * (segments + 1) + s + 1; };
    const auto face = [&](int a, int b, int c) {
        out << "f " << a << '/' << a << '/' << a << ' ' << b << '/' << b << '/' << b << ' ' << c
            << '/' << c << '/' << c << '\n';
    };
    for (int r = 0; r < rings; ++r) {
        for (int s = 0; s < segments; ++s) {
            // Counter-clockwise seen from outside: +Y is the pole at r = 0, φ grows clockwise
            // seen from above (z = −sin φ).
            if (r != 0) {
                face(index(r, s), index(r + 1, s), index(r, s + 1));
            }
            if (r != rings - 1) {
                face(index(r, s + 1), index(r + 1, s), index(r + 1, s + 1));
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 1. Differentials against finite differences of traced offset rays.

/// Finds up to three raster positions in [x0, x1] × [y0, y1] whose paths follow `events` on
/// one smooth piece of the scene and checks their convergence; at least `min_ratios` error
/// ratios must be above the noise, or the convergence rate was not tested.
void expect_converging_differentials(const Scene& scene, const std::vector<Event>& events, float x0,
                                     float x1, float y0, float y1, int min_ratios) {
    const SceneBvh bvh(scene);
    const CameraRays camera(scene.camera, scene.camera.width, scene.camera.height);
    const std::vector<Sample> samples = find_samples(scene, bvh, camera, events, x0, x1, y0, y1, 3);
    EXPECT_GE(samples.size(), 2u) << "too few raster positions whose offset paths stay on one "
                                     "smooth piece of the scene";
    const ConvergenceSummary summary = expect_linear_convergence(samples);
    EXPECT_GE(summary.ratios_checked, min_ratios)
        << "the errors must be above rounding noise for the convergence rate to be checked";
    std::printf(
        "  %zu positions, %d quantities: forward difference at 1/32 px within %.3g, "
        "Richardson within %.3g; %d error ratios in [%.3f, %.3f]\n",
        samples.size(), summary.quantities, summary.worst_error, summary.worst_richardson,
        summary.ratios_checked, summary.min_ratio, summary.max_ratio);
}

TEST(TracedDifferentials, TransferOntoAnObliqueTexturedPlaneConvergesLinearly) {
    const testing::ScratchDirectory scratch("mrt_footprint_render_test");
    json s = base_scene(
        camera_json({0.3f, 1.5f, 4.0f}, {0.0f, 0.0f, -2.0f}, 60.0f, 32, 24, Vec3f::UnitY(), 1.5f));
    s["objects"].push_back(quad(40.0f, Vec3f::Zero()));
    const Scene scene = load_json_scene(scratch.path(), s);
    expect_converging_differentials(scene, {Event::Stop}, 2.0f, 30.0f, 13.0f, 23.0f, 6);
}

TEST(TracedDifferentials, ReflectionOffAProceduralSphereConvergesLinearly) {
    const testing::ScratchDirectory scratch("mrt_footprint_render_test");
    json s = base_scene(camera_json({0.4f, 1.6f, 4.5f}, {0.0f, 0.9f, 0.0f}, 40.0f, 32, 24));
    s["objects"].push_back(quad(40.0f, Vec3f::Zero()));
    s["objects"].push_back(sphere(1.0f, {0.0f, 1.1f, 0.0f}, "mirror"));
    const Scene scene = load_json_scene(scratch.path(), s);
    expect_converging_differentials(scene, {Event::Reflect, Event::Stop}, 10.0f, 22.0f, 13.0f,
                                    19.0f, 6);
}

TEST(TracedDifferentials, ReflectionOffANormalInterpolatedObjMeshConvergesLinearly) {
    const testing::ScratchDirectory scratch("mrt_footprint_render_test");
    write_uv_sphere_obj(scratch.path() / "coarse_sphere.obj", 12, 8);
    json s = base_scene(camera_json({0.4f, 1.6f, 4.5f}, {0.0f, 0.9f, 0.0f}, 40.0f, 32, 24));
    s["objects"].push_back(quad(40.0f, Vec3f::Zero()));
    s["objects"].push_back({{"shape", "mesh"},
                            {"file", "coarse_sphere.obj"},
                            {"material", "mirror"},
                            {"transform", {{"translate", {0.0, 1.1, 0.0}}}}});
    const Scene scene = load_json_scene(scratch.path(), s);
    expect_converging_differentials(scene, {Event::Reflect, Event::Stop}, 10.0f, 22.0f, 13.0f,
                                    19.0f, 6);
}

TEST(TracedDifferentials, RefractionInAndOutOfAGlassSphereConvergesLinearly) {
    const testing::ScratchDirectory scratch("mrt_footprint_render_test");
    json s = base_scene(
        camera_json({0.3f, 3.0f, 3.5f}, {0.0f, 0.8f, 0.0f}, 40.0f, 32, 24, Vec3f::UnitY(), 1.25f));
    s["objects"].push_back(quad(40.0f, Vec3f::Zero()));
    s["objects"].push_back(sphere(1.0f, {0.0f, 1.1f, 0.0f}, "glass"));
    const Scene scene = load_json_scene(scratch.path(), s);
    expect_converging_differentials(scene, {Event::Refract, Event::Refract, Event::Stop}, 9.0f,
                                    23.0f, 6.0f, 18.0f, 6);
}

TEST(TracedDifferentials, RefractionThroughBothSurfacesOfTheDeskLensConvergesLinearly) {
    const testing::ScratchDirectory scratch("mrt_footprint_render_test");
    const fs::path lens = fs::path(MRT_SOURCE_DIR) / "data/meshes/desk-lens.obj";
    // The lens (aperture radius 0.05, cap radius 0.24, axis +Y, faces at |y| ≤ 0.0073,
    // triangles about 1.5 × 1.8 mm at 3 cm from the axis) seen from just above that ring, so
    // that a triangle spans several of the offsets; a textured floor below, its diagonal far
    // from where the rays land.
    json s = base_scene(camera_json({0.03f, 0.025f, 0.002f}, {0.03f, 0.0f, 0.0f}, 60.0f, 32, 24,
                                    {0.0f, 0.0f, -1.0f}, 0.8f));
    s["objects"].push_back(quad(4.0f, {1.5f, -0.1f, 0.0f}));
    s["objects"].push_back({{"shape", "mesh"}, {"file", lens.string()}, {"material", "glass"}});
    const Scene scene = load_json_scene(scratch.path(), s);
    expect_converging_differentials(scene, {Event::Refract, Event::Refract, Event::Stop}, 4.0f,
                                    28.0f, 3.0f, 21.0f, 6);
}

// ---------------------------------------------------------------------------------------------
// 2. Stiff cases: full renders and the footprints the helper propagates stay finite and bounded.

constexpr TextureFilter kTextureFilters[] = {TextureFilter::None, TextureFilter::Distance,
                                             TextureFilter::Trilinear, TextureFilter::Anisotropic};

/// The largest radiance a pixel can have in these scenes. Their materials have no specular
/// term and split each hit's weight between reflection, transmission and local scattering
/// (summing to at most 1, also under total internal reflection), so every pixel is a weighted
/// mean of the background and of local terms ambient·albedo + Σ I·cosθ/d²·albedo/π with
/// albedo ≤ 1; the scenes keep every point light at least 1 unit from every surface.
float radiance_bound(const Scene& scene) {
    float local = scene.ambient.maxCoeff();
    for (const PointLight& light : scene.point_lights) {
        local += light.intensity.maxCoeff() / kPi;
    }
    return std::max(scene.background.maxCoeff(), local);
}

/// A labelled render.
struct Render {
    std::string label;
    Image image;
};

/// Renders the scene with both tracers (whitted at the pixel centres, distributed with a fixed
/// 4 samples per pixel) and every texture filter, and checks that every pixel is finite and
/// within [0, radiance_bound].
std::vector<Render> expect_bounded_renders(const Scene& scene) {
    const SceneBvh bvh(scene);
    const float bound = radiance_bound(scene);
    std::vector<Render> renders;
    for (const TextureFilter filter : kTextureFilters) {
        const TextureSampler textures(scene, filter);
        RenderOptions options = testing::camera_options(scene);
        options.texture_filter = filter;
        renders.push_back(
            {"whitted " + to_string(filter), render_whitted(scene, bvh, textures, options).image});
        const DistributedOptions four{.sampling = DistributedSampling::Fixed, .spp = 4};
        renders.push_back({"distributed " + to_string(filter),
                           render_distributed(scene, bvh, textures, options, four).image});
    }
    for (const Render& render : renders) {
        int bad = 0;
        std::string first_bad;
        for (int y = 0; y < render.image.height(); ++y) {
            for (int x = 0; x < render.image.width(); ++x) {
                const Rgb c = render.image.at(x, y);
                if (!all_finite(c) || c.minCoeff() < 0.0f || c.maxCoeff() > bound) {
                    if (bad++ == 0) {
                        std::ostringstream os;
                        os << "pixel (" << x << ", " << y << ") = " << c.transpose();
                        first_bad = os.str();
                    }
                }
            }
        }
        EXPECT_EQ(bad, 0) << render.label << ": pixels not finite or outside [0, " << bound
                          << "], first " << first_bad;
    }
    return renders;
}

/// Largest diameter a footprint can have at distance t once every differential vector is
/// capped at √kMaxSquaredLength: each column of start_dev + t·incr_dev is at most (1 + t) times
/// that long, and the largest singular value at most √2 times the longest column.
float footprint_cap(float t) {
    return 2.0f * std::sqrt(2.0f) * std::sqrt(RayDifferential::kMaxSquaredLength) * (1.0f + t);
}

/// Every vertex of a path carries finite differentials, finite uv derivatives, and a footprint
/// cone finite and within the cap at the vertex and along the ray leaving it.
void expect_finite_footprints(const std::vector<PathVertex>& path, const std::string& label) {
    for (std::size_t i = 0; i < path.size(); ++i) {
        const PathVertex& v = path[i];
        SCOPED_TRACE(::testing::Message()
                     << label << ", vertex " << i << ", cos incidence " << v.cos_incidence);
        EXPECT_TRUE(v.differential.finite());
        EXPECT_TRUE(all_finite(v.duv_dx) && all_finite(v.duv_dy));
        const FootprintCone cone = FootprintCone::from_differential(v.direction, v.differential);
        for (const float t : {0.0f, 1.0f, 1e3f}) {
            const float major = cone.max_diameter(t);
            const float minor = cone.min_diameter(t);
            EXPECT_TRUE(std::isfinite(major) && std::isfinite(minor)) << "t = " << t;
            EXPECT_LE(major, footprint_cap(t)) << "t = " << t;
            EXPECT_GE(minor, 0.0f) << "t = " << t;
            EXPECT_LE(minor, major) << "t = " << t;
        }
    }
}

/// Without a bounce, the footprint's section orthogonal to the ray at its hit is the pixel
/// cone at that distance, whatever the surface's slope: the transfer only slides the offset
/// points along the ray (eq. 10). At grazing incidence that slide is thousands of times the
/// section, so the section survives only if the transfer does not lose it to cancellation.
/// Where the slide exceeds the cap on differentials, the whole vector is shortened and the
/// section with it: then it can only be smaller than the pixel cone.
void expect_section_is_the_pixel_cone(const CameraRays& camera, float x, float y,
                                      const PathVertex& hit) {
    const RayDifferential& rd = hit.differential;
    const float longest = std::max(rd.dp_dx.norm(), rd.dp_dy.norm());
    const FootprintCone pixel = FootprintCone::from_differential(camera.pinhole_ray(x, y).direction,
                                                                 camera.pinhole_differential(x, y));
    const FootprintCone section = FootprintCone::from_differential(hit.direction, rd);
    SCOPED_TRACE(::testing::Message() << "raster (" << x << ", " << y << "), cos incidence "
                                      << hit.cos_incidence << ", |dp| " << longest);
    const float major = pixel.max_diameter(hit.distance);
    const float minor = pixel.min_diameter(hit.distance);
    if (longest >= 0.99f * std::sqrt(RayDifferential::kMaxSquaredLength)) {
        EXPECT_LE(section.max_diameter(0.0f), 1.001f * major);
        EXPECT_LE(section.min_diameter(0.0f), 1.001f * minor);
        return;
    }
    EXPECT_NEAR(section.max_diameter(0.0f), major, 1e-3f * major);
    EXPECT_NEAR(section.min_diameter(0.0f), minor, 1e-3f * minor);
}

/// The raster position on the segment from `hitting` (whose camera ray meets `material`
/// first) to `missing` (whose ray does not) where one turns into the other, to float
/// resolution: the last position still meeting it, the most grazing hit along that line.
Vec2f last_hit(const Scene& scene, const SceneBvh& bvh, const CameraRays& camera,
               const std::string& material, Vec2f hitting, Vec2f missing) {
    const auto hits = [&](const Vec2f& p) {
        const std::vector<PathVertex> path =
            trace_path(scene, bvh, camera, p.x(), p.y(), {Event::Stop});
        return !path.empty() && scene.materials[path[0].material].name == material;
    };
    EXPECT_TRUE(hits(hitting));
    EXPECT_FALSE(hits(missing));
    for (int i = 0; i < 60; ++i) {
        const Vec2f mid = 0.5f * (hitting + missing);
        if (mid == hitting || mid == missing) {
            break;
        }
        (hits(mid) ? hitting : missing) = mid;
    }
    return hitting;
}

/// Raster position of world point p (its pinhole projection).
Vec2f project(const CameraRays& camera, const Vec3f& p) {
    const Vec3f v = p - camera.camera().eye;
    const Vec3f on_plane = v / v.dot(camera.forward());
    const float step_x = camera.pixel_step_x().norm();
    const float step_y = camera.pixel_step_y().norm();
    const float half_width = 0.5f * step_x * static_cast<float>(camera.width());
    const float half_height = 0.5f * step_y * static_cast<float>(camera.height());
    return {(on_plane.dot(camera.right()) + half_width) / step_x,
            (half_height - on_plane.dot(camera.up())) / step_y};
}

TEST(StiffFootprints, TexturedPlaneAtGrazingIncidenceStaysFiniteAndBounded) {
    // The optical axis meets the plane 89.99° from its normal, through the centre of pixel
    // (16, 12) of a 33×25 image; the rows above see the horizon. A fine texture (tiles of
    // 1.25 units) makes every filter work over long, thin footprints.
    const testing::ScratchDirectory scratch("mrt_footprint_render_test");
    const float grazing = 0.01f * kPi / 180.0f;
    const Vec3f eye(0.0f, 1.0f, 0.0f);
    const Vec3f axis(0.0f, -std::sin(grazing), -std::cos(grazing));
    json s = base_scene(camera_json(eye, eye + axis, 40.0f, 33, 25));
    s["materials"]["fine_floor"] = {
        {"diffuse", 1},
        {"texture", {{"file", "checker.exr"}, {"srgb", false}, {"uv_scale", 20000}}}};
    s["objects"].push_back(quad(2e5f, Vec3f::Zero(), "fine_floor"));
    s["lights"].push_back(point_light({0.0f, 10.0f, -20.0f}, 30.0f));
    const Scene scene = load_json_scene(scratch.path(), s);
    expect_bounded_renders(scene);

    const SceneBvh bvh(scene);
    const CameraRays camera(scene.camera, 33, 25);
    const std::vector<PathVertex> centre =
        trace_path(scene, bvh, camera, 16.5f, 12.5f, {Event::Stop});
    ASSERT_EQ(centre.size(), 1u);
    EXPECT_NEAR(centre[0].cos_incidence, std::sin(grazing), 1e-3f * std::sin(grazing));
    expect_finite_footprints(centre, "pixel centre at 89.99°");
    expect_section_is_the_pixel_cone(camera, 16.5f, 12.5f, centre[0]);
    // Up the centre column to the horizon: the last ray that still meets the plane, at its far
    // edge 1e5 units away.
    const Vec2f edge = last_hit(scene, bvh, camera, "fine_floor", {16.5f, 12.5f}, {16.5f, 11.5f});
    const std::vector<PathVertex> far =
        trace_path(scene, bvh, camera, edge.x(), edge.y(), {Event::Stop});
    ASSERT_EQ(far.size(), 1u);
    EXPECT_LT(far[0].cos_incidence, 2e-5f);
    expect_finite_footprints(far, "last ray meeting the plane");
    expect_section_is_the_pixel_cone(camera, edge.x(), edge.y(), far[0]);
}

TEST(StiffFootprints, CameraRaysTangentToASphereStayFiniteAndBounded) {
    // The mirror sphere's radius puts its silhouette exactly through the centres of the pixels
    // 6.5 pixels above, below, left and right of the axis and half a pixel across (the camera
    // looks at the centre, so eight pixel centres by symmetry); tangent rays graze the
    // tessellation and the reflections leave along the surface onto a textured floor.
    const testing::ScratchDirectory scratch("mrt_footprint_render_test");
    const Vec3f centre(0.0f, 0.5f, 0.0f);
    json s = base_scene(camera_json({0.0f, 0.5f, 6.0f}, centre, 40.0f, 32, 24));
    s["objects"].push_back(quad(40.0f, {0.0f, -1.5f, 0.0f}));
    s["lights"].push_back(point_light({3.0f, 5.0f, 4.0f}, 30.0f));
    const Scene probe = load_json_scene(scratch.path(), s, "probe.json");
    const CameraRays probe_camera(probe.camera, 32, 24);
    const Vec3f tangent = probe_camera.pinhole_ray(16.5f, 5.5f).direction;
    const Vec3f to_centre = centre - probe.camera.eye;
    const float radius = tangent.cross(to_centre).norm();  // distance of the ray from the centre
    s["objects"].push_back(sphere(radius, centre, "mirror", 256, 128));
    const Scene scene = load_json_scene(scratch.path(), s);
    expect_bounded_renders(scene);

    const SceneBvh bvh(scene);
    const CameraRays camera(scene.camera, 32, 24);
    int grazing_hits = 0;
    for (const Vec2f& offset :
         {Vec2f(0.5f, -6.5f), Vec2f(-0.5f, -6.5f), Vec2f(0.5f, 6.5f), Vec2f(-0.5f, 6.5f),
          Vec2f(6.5f, 0.5f), Vec2f(6.5f, -0.5f), Vec2f(-6.5f, 0.5f), Vec2f(-6.5f, -0.5f)}) {
        const Vec2f pixel_centre = Vec2f(16.0f, 12.0f) + offset;
        const Vec3f d = camera.pinhole_ray(pixel_centre.x(), pixel_centre.y()).direction;
        EXPECT_NEAR(d.cross(to_centre).norm(), radius, 1e-5f * radius);
        expect_finite_footprints(trace_path(scene, bvh, camera, pixel_centre.x(), pixel_centre.y(),
                                            {Event::Reflect, Event::Stop}),
                                 "tangent pixel centre");
        // Towards the centre, to the last ray that still hits the tessellated sphere.
        const Vec2f inside = pixel_centre - offset / offset.norm();
        const Vec2f edge = last_hit(scene, bvh, camera, "mirror", inside,
                                    pixel_centre + 0.5f * offset / offset.norm());
        const std::vector<PathVertex> transfer =
            trace_path(scene, bvh, camera, edge.x(), edge.y(), {Event::Stop});
        ASSERT_EQ(transfer.size(), 1u);
        // The last hit is on a triangle of the polygonal silhouette, whose slope to the ray is
        // at most the angle between neighbouring facets.
        EXPECT_LT(transfer[0].cos_incidence, 2.0f * kPi / 256.0f);
        grazing_hits += transfer[0].cos_incidence < 1e-3f ? 1 : 0;
        expect_section_is_the_pixel_cone(camera, edge.x(), edge.y(), transfer[0]);
        expect_finite_footprints(
            trace_path(scene, bvh, camera, edge.x(), edge.y(), {Event::Reflect, Event::Stop}),
            "grazing hit on the silhouette");
    }
    EXPECT_GE(grazing_hits, 4) << "the silhouette rays above and below the sphere graze a "
                                  "facet seen edge-on";
}

TEST(StiffFootprints, GlassSphereAtTheCriticalAngleStaysFiniteAndBounded) {
    // The camera sits inside a glass sphere (ior 1.5) centred 1 unit to its right; a ray meets
    // the surface from inside at sin θ = (its distance from the centre) / radius, and the
    // radius makes that exactly 1/1.5 for the centres of pixels (4, 11), (4, 12), (27, 11) and
    // (27, 12): the boundary of total internal reflection runs through them. Outside, a
    // textured floor and wall.
    const testing::ScratchDirectory scratch("mrt_footprint_render_test");
    const Vec3f centre(1.0f, 0.0f, 0.0f);
    json s = base_scene(camera_json(Vec3f::Zero(), {0.0f, 0.0f, -1.0f}, 90.0f, 32, 24));
    s["objects"].push_back(quad(40.0f, {0.0f, -3.0f, 0.0f}));
    s["objects"].push_back(
        {{"shape", "quad"},
         {"size", {40, 40}},
         {"material", "floor"},
         {"transform",
          {{"rotate", {{"axis", {0, 0, 1}}, {"degrees", -90}}}, {"translate", {-5, 0, 0}}}}});
    s["lights"].push_back(point_light({-3.0f, 1.5f, 1.0f}, 30.0f));
    const Scene probe = load_json_scene(scratch.path(), s, "probe.json");
    const CameraRays probe_camera(probe.camera, 32, 24);
    const float ior = 1.5f;
    const float radius = ior * probe_camera.pinhole_ray(4.5f, 11.5f).direction.cross(centre).norm();
    ASSERT_GT(radius, centre.norm()) << "the camera must be inside the sphere";
    s["objects"].push_back(sphere(radius, centre, "glass", 256, 128));
    const Scene scene = load_json_scene(scratch.path(), s);
    expect_bounded_renders(scene);

    const SceneBvh bvh(scene);
    const CameraRays camera(scene.camera, 32, 24);
    for (const Vec2f& pixel_centre :
         {Vec2f(4.5f, 11.5f), Vec2f(4.5f, 12.5f), Vec2f(27.5f, 11.5f), Vec2f(27.5f, 12.5f)}) {
        expect_finite_footprints(trace_path(scene, bvh, camera, pixel_centre.x(), pixel_centre.y(),
                                            {Event::Refract, Event::Refract, Event::Stop}),
                                 "pixel centre at the critical angle");
    }
    // Along row 11.5, the exact boundary on the tessellated sphere: the outermost columns
    // refract, the inner ones are totally reflected.
    const auto totally_reflected = [&](float x) {
        const auto path = trace_path(scene, bvh, camera, x, 11.5f, {Event::Refract});
        return path.size() == 1 && path[0].fallback;
    };
    float refracting = 1.0f;
    float reflected = 8.0f;
    ASSERT_FALSE(totally_reflected(refracting));
    ASSERT_TRUE(totally_reflected(reflected));
    for (int i = 0; i < 40; ++i) {
        const float mid = 0.5f * (refracting + reflected);
        (totally_reflected(mid) ? reflected : refracting) = mid;
    }
    const std::vector<PathVertex> critical =
        trace_path(scene, bvh, camera, refracting, 11.5f, {Event::Refract, Event::Stop});
    ASSERT_FALSE(critical.empty());
    EXPECT_FALSE(critical[0].fallback);
    EXPECT_LT(std::abs(critical[0].direction.dot(critical[0].shading_normal)), 1e-3f)
        << "at the critical angle the refracted ray leaves along the surface";
    expect_finite_footprints(critical, "refraction at the critical angle");
    expect_finite_footprints(
        trace_path(scene, bvh, camera, reflected, 11.5f, {Event::Refract, Event::Stop}),
        "total internal reflection at the critical angle");
}

/// Writes a textured 4×4-quad grid over [−2, 2]² at y = 0 with two zero-area triangles (a
/// repeated vertex, three collinear vertices) that the loader drops, and a file of slivers
/// 0.05 above it: each 2 long, of relative width 1e-2, 1e-4 and 1e-6, with normals and uvs
/// that change completely across that width, and one with all three uvs equal.
void write_degenerate_meshes(const fs::path& dir) {
    std::ofstream grid(dir / "grid.obj");
    for (int j = 0; j <= 4; ++j) {
        for (int i = 0; i <= 4; ++i) {
            grid << "v " << i - 2 << " 0 " << j - 2 << "\nvt " << i / 4.0 << ' ' << j / 4.0
                 << "\nvn 0 1 0\n";
        }
    }
    const auto corner = [](int i, int j) { return j * 5 + i + 1; };
    const auto face = [](std::ostream& out, int a, int b, int c) {
        out << "f " << a << '/' << a << '/' << a << ' ' << b << '/' << b << '/' << b << ' ' << c
            << '/' << c << '/' << c << '\n';
    };
    for (int j = 0; j < 4; ++j) {
        for (int i = 0; i < 4; ++i) {
            face(grid, corner(i, j), corner(i, j + 1), corner(i + 1, j + 1));
            face(grid, corner(i, j), corner(i + 1, j + 1), corner(i + 1, j));
        }
    }
    face(grid, corner(0, 0), corner(1, 0), corner(2, 0));  // collinear
    face(grid, corner(1, 1), corner(1, 1), corner(2, 2));  // repeated vertex

    std::ofstream slivers(dir / "slivers.obj");
    slivers << std::setprecision(9);
    int vertex = 0;
    const auto sliver = [&](double x, double width, bool flat_uv) {
        slivers << "v " << x << " 0.05 -1\nvt 0 0\nvn 0 1 0\n";
        slivers << "v " << x + width << " 0.05 0\nvt " << (flat_uv ? "0 0" : "1 0.5")
                << "\nvn 0.707107 0.707107 0\n";
        slivers << "v " << x << " 0.05 1\nvt " << (flat_uv ? "0 0" : "0 1") << "\nvn 0 1 0\n";
        face(slivers, vertex + 1, vertex + 2, vertex + 3);
        vertex += 3;
    };
    sliver(-1.5, 2e-2, false);
    sliver(-0.5, 2e-4, false);
    sliver(0.5, 2e-6, false);
    sliver(1.5, 0.3, true);
}

TEST(StiffFootprints, TexturedMeshWithZeroAreaAndSliverTrianglesStaysFiniteAndBounded) {
    const testing::ScratchDirectory scratch("mrt_footprint_render_test");
    write_degenerate_meshes(scratch.path());
    json s = base_scene(camera_json({0.3f, 2.5f, 3.5f}, {0.0f, 0.0f, 0.0f}, 60.0f, 32, 24));
    s["objects"].push_back({{"shape", "mesh"}, {"file", "grid.obj"}, {"material", "floor"}});
    s["objects"].push_back(
        {{"shape", "mesh"}, {"file", "slivers.obj"}, {"material", "textured_mirror"}});
    s["objects"].push_back(quad(40.0f, {0.0f, -1.0f, 0.0f}));
    s["lights"].push_back(point_light({1.0f, 4.0f, 2.0f}, 30.0f));
    if (!fs::exists(scratch.path() / "checker.exr")) {
        write_checker(scratch.path() / "checker.exr");
    }
    std::ofstream(scratch.path() / "scene.json") << s.dump(2);
    std::vector<std::string> warnings;
    SceneLoadOptions options;
    options.warn = [&](const std::string& w) { warnings.push_back(w); };
    Scene scene = load_scene(scratch.path() / "scene.json", options);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("dropped 2 degenerate triangles"), std::string::npos) << warnings[0];
    ASSERT_EQ(scene.meshes.size(), 3u);
    Mesh& slivers = scene.meshes[1];
    ASSERT_EQ(slivers.triangle_count(), 4u) << "the loader keeps slivers";
    // What the loader would drop, as a scene built in code can still hold it: exact zero-area
    // triangles (a repeated vertex, three collinear vertices) and a sliver of relative width
    // 1e-12 (near x = 0, where such an offset is representable) with a tilted apex normal.
    const auto add_vertex = [&](const Vec3f& p, const Vec3f& n, const Vec2f& uv) {
        slivers.positions.push_back(p);
        slivers.normals.push_back(n.normalized());
        slivers.uvs.push_back(uv);
        return static_cast<std::uint32_t>(slivers.positions.size() - 1);
    };
    const Vec3f up = Vec3f::UnitY();
    const Vec3f tilted(1.0f, 1.0f, 0.0f);
    const std::uint32_t a = add_vertex({1.0f, 0.05f, -1.0f}, up, {0.0f, 0.0f});
    const std::uint32_t b = add_vertex({1.0f, 0.05f, 0.0f}, tilted, {0.5f, 0.5f});
    const std::uint32_t c = add_vertex({1.0f, 0.05f, 1.0f}, up, {1.0f, 0.0f});
    const std::uint32_t e = add_vertex({0.0f, 0.06f, -1.0f}, up, {0.0f, 0.0f});
    const std::uint32_t f = add_vertex({2e-12f, 0.06f, 0.0f}, tilted, {1.0f, 0.5f});
    const std::uint32_t g = add_vertex({0.0f, 0.06f, 1.0f}, up, {0.0f, 1.0f});
    for (const std::array<std::uint32_t, 3>& t :
         {std::array<std::uint32_t, 3>{a, a, c}, std::array<std::uint32_t, 3>{a, b, c},
          std::array<std::uint32_t, 3>{e, f, g}}) {
        slivers.triangles.push_back(t);
        slivers.materials.push_back(slivers.materials.front());
    }
    expect_bounded_renders(scene);

    // Rays aimed at each sliver's centroid, traced onto it and off it as a mirror.
    const SceneBvh bvh(scene);
    const CameraRays camera(scene.camera, 32, 24);
    int sliver_hits = 0;
    for (std::size_t t = 0; t < slivers.triangle_count(); ++t) {
        const auto& tri = slivers.triangles[t];
        const Vec3f centroid =
            (slivers.positions[tri[0]] + slivers.positions[tri[1]] + slivers.positions[tri[2]]) /
            3.0f;
        const Vec2f raster = project(camera, centroid);
        const std::vector<PathVertex> path =
            trace_path(scene, bvh, camera, raster.x(), raster.y(), {Event::Reflect, Event::Stop});
        ASSERT_FALSE(path.empty());
        if (path[0].mesh == 1 && path[0].triangle == t) {
            ++sliver_hits;
        }
        expect_finite_footprints(path, "aimed at sliver " + std::to_string(t));
    }
    EXPECT_GE(sliver_hits, 4) << "the rays aimed at the slivers the loader keeps should meet them";
}

/// A textured floor (tiles of 1.5 units, several pixels wide) and, with `spheres`, a mirror
/// and a glass sphere on it, lit by a point light; everything translated by `offset`: the
/// objects through an instanced group, the camera and the light moved along.
json translated_scene(const Vec3f& offset, bool spheres) {
    const Vec3f eye = Vec3f(0.4f, 1.6f, 4.5f) + offset;
    json s = base_scene(camera_json(eye, Vec3f(0.0f, 0.9f, 0.0f) + offset, 40.0f, 32, 24));
    s["materials"]["floor"]["texture"]["uv_scale"] = 1;
    json content = json::array();
    content.push_back(quad(12.0f, Vec3f::Zero()));
    if (spheres) {
        content.push_back(sphere(0.8f, {-0.9f, 0.8f, 0.0f}, "mirror"));
        content.push_back(sphere(0.7f, {0.9f, 0.7f, 0.5f}, "glass"));
    }
    s["groups"] = {{"content", {{"objects", content}}}};
    s["objects"].push_back({{"instance", "content"},
                            {"transform", {{"translate", {offset.x(), offset.y(), offset.z()}}}}});
    s["lights"].push_back(point_light(Vec3f(2.0f, 4.0f, 3.0f) + offset, 30.0f));
    // Kept as written: what is tested is the tracers on float world coordinates far from the
    // origin, which the loader would otherwise re-base on the eye (common/scene/world_origin.h).
    s["world_origin"] = {0, 0, 0};
    return s;
}

/// Mean absolute difference of two images over all pixels and channels.
double mean_abs_difference(const Image& a, const Image& b) {
    double sum = 0.0;
    for (std::size_t k = 0; k < a.data().size(); ++k) {
        sum += std::abs(static_cast<double>(a.data()[k]) - b.data()[k]);
    }
    return sum / static_cast<double>(a.data().size());
}

TEST(StiffFootprints, SceneFarFromTheOriginRendersAsAtTheOrigin) {
    // At 1e5 units a float has a spacing of 1/128: the camera, the light and every hit point
    // are rounded by up to 1/256, which moves what a pixel centre sees by about 1/30 of a
    // pixel here. Tolerances (mean over all pixels and channels, the mean pixel being ~0.22):
    // - the floor alone (camera and shadow rays only): 1e-3; measured 1.1e-4 to 1.4e-4.
    // - with a mirror and a glass sphere: 3e-2; measured 1.4e-2 to 2.0e-2 (maximum per pixel
    //   0.36). Secondary rays leave a surface offset along its normal by the hit's error bound,
    //   32·FLT_EPSILON·|p| (common/math/ray.h): 0.3 units at 8e4, a third of a sphere's radius, and
    //   what the spheres show moves with it (a reflection lands ~0.2 units away on the
    //   floor). That offset, not the rounding, is what this tolerance has to absorb.
    const testing::ScratchDirectory scratch("mrt_footprint_render_test");
    const Vec3f offset(6e4f, 0.0f, -8e4f);
    for (const bool spheres : {false, true}) {
        SCOPED_TRACE(spheres ? "floor, mirror and glass spheres" : "floor alone");
        const Scene near =
            load_json_scene(scratch.path(), translated_scene(Vec3f::Zero(), spheres), "near.json");
        const Scene far =
            load_json_scene(scratch.path(), translated_scene(offset, spheres), "far.json");
        EXPECT_NEAR(far.camera.eye.norm(), 1e5f, 10.0f);
        const std::vector<Render> near_renders = expect_bounded_renders(near);
        const std::vector<Render> far_renders = expect_bounded_renders(far);
        ASSERT_EQ(near_renders.size(), far_renders.size());
        for (std::size_t i = 0; i < near_renders.size(); ++i) {
            const double difference =
                mean_abs_difference(near_renders[i].image, far_renders[i].image);
            EXPECT_LE(difference, spheres ? 3e-2 : 1e-3) << near_renders[i].label;
            std::printf("  %s, %s: mean absolute difference %.3g\n",
                        spheres ? "with spheres" : "floor alone", near_renders[i].label.c_str(),
                        difference);
        }
    }

    const Scene far = load_json_scene(scratch.path(), translated_scene(offset, true), "far.json");
    const SceneBvh bvh(far);
    const CameraRays camera(far.camera, 32, 24);
    // The surface's derivatives come from its edges alone, so they must not depend on where
    // the scene is: taken from world-space vertices they were off by up to 26 % here.
    const Scene near =
        load_json_scene(scratch.path(), translated_scene(Vec3f::Zero(), true), "near.json");
    const SceneBvh near_bvh(near);
    const CameraRays near_camera(near.camera, 32, 24);
    int compared = 0;
    float worst = 0.0f;
    for (float x = 0.5f; x < 32.0f; x += 1.0f) {
        for (float y = 0.5f; y < 24.0f; y += 1.0f) {
            const auto a = trace_path(near, near_bvh, near_camera, x, y, {Event::Reflect});
            const auto b = trace_path(far, bvh, camera, x, y, {Event::Reflect});
            if (a.empty() || b.empty() || a[0].triangle != b[0].triangle ||
                a[0].mesh != b[0].mesh || a[0].fallback || b[0].fallback ||
                near.materials[a[0].material].reflectivity <= 0.0f) {
                continue;
            }
            for (const auto& [da, db] :
                 {std::pair{a[0].differential.dd_dx, b[0].differential.dd_dx},
                  std::pair{a[0].differential.dd_dy, b[0].differential.dd_dy}}) {
                worst = std::max(worst, (da - db).norm() / da.norm());
            }
            ++compared;
        }
    }
    EXPECT_GE(compared, 10) << "too few pixels see the mirror sphere on the same triangle";
    EXPECT_LT(worst, 1e-2f);
    std::printf("  reflected differentials at 1e5 vs at the origin: %d pixels, within %.3g\n",
                compared, worst);
    for (const std::vector<Event>& events :
         {std::vector<Event>{Event::Reflect, Event::Stop},
          std::vector<Event>{Event::Refract, Event::Refract, Event::Stop}}) {
        for (float x = 2.5f; x < 32.0f; x += 4.0f) {
            for (float y = 2.5f; y < 24.0f; y += 4.0f) {
                expect_finite_footprints(trace_path(far, bvh, camera, x, y, events),
                                         "1e5 from the origin");
            }
        }
    }
}

}  // namespace
}  // namespace mrt
