#pragma once
// The in-memory scene description every tool works from: camera, lights, materials, textures,
// unique meshes and a hierarchy of instanced groups. Loaded from JSON by scene_loader.h; the
// format is documented in docs/scene-format.md. All lengths are in scene units, all angles in
// radians unless a field says otherwise, all colours linear RGB.

#include "common/math/math.h"
#include "common/mesh/mesh.h"
#include "common/scene/mesh_light.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <span>
#include <string>
#include <vector>

namespace mrt {

/// Pinhole or thin-lens perspective camera.
struct Camera {
    Vec3f eye{0.0f, 0.0f, 5.0f};      ///< Centre of projection / lens centre (world).
    Vec3f look_at{0.0f, 0.0f, 0.0f};  ///< Point the optical axis passes through (world).
    Vec3f up{0.0f, 1.0f, 0.0f};       ///< Up hint; need not be orthogonal to the view direction.
    float vertical_fov = 0.785398f;   ///< Full vertical field of view (radians).
    int width = 512;                  ///< Image width in pixels.
    int height = 512;                 ///< Image height in pixels.
    float aperture_radius = 0.0f;     ///< Thin-lens radius (world units); 0 is a pinhole.
    float focal_distance = 0.0f;      ///< Distance to the plane in focus along the view axis.
    /// Width of a pixel over its height: 1 is square; 2 stretches the view horizontally over the
    /// same pixels (an anamorphic image, displayed at twice its width).
    float pixel_aspect = 1.0f;
};

/// Isotropic point light.
struct PointLight {
    Vec3f position{0.0f, 0.0f, 0.0f};  ///< World position.
    Rgb intensity{1.0f, 1.0f, 1.0f};   ///< Radiant intensity (W/sr) per channel.
};

/// Flat elliptical area light: points centre + a·u + b·v with a² + b² ≤ 1. It emits uniform
/// radiance from the side its normal normalize(u × v) faces (both sides when two_sided).
struct EllipticalAreaLight {
    Vec3f center{0.0f, 0.0f, 0.0f};       ///< World position of the ellipse centre.
    Vec3f semi_axis_u{1.0f, 0.0f, 0.0f};  ///< First semi-axis (world, length = semi-axis length).
    Vec3f semi_axis_v{0.0f, 0.0f, 1.0f};  ///< Second semi-axis (world).
    Rgb radiance{1.0f, 1.0f, 1.0f};       ///< Emitted radiance (W/(m²·sr)) per channel.
    bool two_sided = false;               ///< Emit from both faces.

    Vec3f normal() const { return semi_axis_u.cross(semi_axis_v).normalized(); }
    float area() const { return kPi * semi_axis_u.cross(semi_axis_v).norm(); }
};

/// What a texture's texels are read as.
enum class TextureChannel : std::uint8_t {
    /// Grey or RGB (one or two channels are grey, three or more RGB; alpha is ignored).
    Colour,
    /// One value, the opacity of a cut-out (an OBJ's map_d): the image's alpha channel where it
    /// has one, else its first channel (a grey mask). Never linearised.
    Opacity,
};

/// An image texture, referred to by materials.
struct Texture {
    std::filesystem::path path;  ///< Resolved absolute path of the image file.
    bool srgb = true;  ///< Linearise with the sRGB curve when loaded (8-bit colour images).
    TextureChannel channel = TextureChannel::Colour;
};

/// Phong-style material of the paper's scenes, plus reflection, refraction and roughness.
struct Material {
    std::string name;
    Rgb diffuse{0.8f, 0.8f, 0.8f};   ///< Diffuse albedo (multiplied by the texture when present).
    Rgb specular{0.0f, 0.0f, 0.0f};  ///< Phong specular colour.
    float phong_exponent = 32.0f;    ///< Phong exponent (≥ 0).
    float reflectivity = 0.0f;       ///< Fraction of light mirrored, in [0, 1].
    float transparency = 0.0f;       ///< Fraction of light refracted, in [0, 1 − reflectivity].
    float ior = 1.5f;                ///< Index of refraction of the inside (≥ 1 typical, > 0).
    float roughness = 0.0f;          ///< Blur of reflection/refraction (0 = perfect mirror).
    /// Radiance emitted from the front face (an OBJ `Ke`); a mesh face of a material that emits
    /// is also a light (Scene::mesh_lights).
    Rgb emission{0.0f, 0.0f, 0.0f};
    int texture = -1;                              ///< Index into Scene::textures, or −1.
    Affine2f uv_transform = Affine2f::Identity();  ///< Applied to mesh UVs before lookup.
    /// Index into Scene::textures of the cut-out's opacity (TextureChannel::Opacity), or −1:
    /// where it is below ½ the surface is absent for whitted and distributed; the cone tracer
    /// and the points weigh the surface by it, filtered over their footprints. It is looked up
    /// through the same uv transform as the colour texture.
    int opacity_texture = -1;

    bool reflects() const { return reflectivity > 0.0f; }
    bool emits() const { return (emission > 0.0f).any(); }
    bool refracts() const { return transparency > 0.0f; }
    bool cut_out() const { return opacity_texture >= 0; }
};

/// One child of a group: a mesh or another group, placed by a transform.
struct Instance {
    enum class Kind : std::uint8_t { Mesh, Group };
    Kind kind = Kind::Mesh;
    std::uint32_t index = 0;                    ///< Into Scene::meshes or Scene::groups.
    Affine3f transform = Affine3f::Identity();  ///< Child space → group space.
};

/// A named collection of instances; groups may instance other groups (never cyclically).
struct Group {
    std::string name;
    std::vector<Instance> children;
};

struct Scene {
    std::filesystem::path file;  ///< The scene file it was loaded from (for messages).
    Camera camera;
    Rgb background{0.0f, 0.0f, 0.0f};  ///< Radiance of rays that leave the scene.
    Rgb ambient{0.0f, 0.0f, 0.0f};     ///< Constant ambient light (Whitted's ambient term).
    int max_depth = 8;                 ///< Maximum number of reflection/refraction bounces.
    std::vector<PointLight> point_lights;
    std::vector<EllipticalAreaLight> area_lights;
    /// Lights made of the geometry's emissive faces (common/scene/emissive_lights.h): derived
    /// by the loaders from the meshes and materials, never written to a file.
    std::vector<MeshAreaLight> mesh_lights;
    std::vector<Material> materials;
    std::vector<Texture> textures;
    std::vector<Mesh> meshes;   ///< Unique geometry, each in its own object space.
    std::vector<Group> groups;  ///< groups[root] is the world.
    std::uint32_t root = 0;
    /// Where this scene's origin is in the coordinates of the file it was written in: world space
    /// here (camera, lights, the world's transforms) is relative to it. The loader re-bases a
    /// scene whose eye is far from the file's origin on the eye (common/scene/world_origin.h); zero
    /// for a scene loaded with the numbers it was written with.
    Vec3d world_origin{0.0, 0.0, 0.0};

    /// Number of triangles after expanding every instance.
    std::uint64_t instanced_triangle_count() const;
    /// Number of unique triangles stored.
    std::uint64_t unique_triangle_count() const;
};

/// The deepest group nesting any tool accepts, whatever the `group-nesting` budget says
/// (common/system/budgets.h): the tracers' traversals and the preprocessor's builders recurse once
/// per level, and at this depth their frames stay far below a worker thread's stack.
inline constexpr std::uint64_t kMaxSupportedGroupNesting = 256;

/// What one group stands for once every instance below it is expanded. Counts saturate at the
/// largest uint64 instead of wrapping.
struct GroupExpansion {
    std::uint64_t levels = 1;  ///< Levels of groups, this one included (1: it holds meshes only).
    std::uint64_t instances = 0;  ///< Mesh placements.
    std::uint64_t triangles = 0;  ///< Triangles of those placements.
};

/// The expansion of every group (indexed like Scene::groups), computed without recursion, so a
/// chain of a million groups is counted, not overflowed; `mesh_triangles[m]` is mesh m's
/// triangle count (the loader knows it for procedural meshes before generating them). Throws
/// mrt::Error naming scene.file on an out-of-range index or a cycle.
std::vector<GroupExpansion> expand_groups(const Scene& scene,
                                          std::span<const std::uint64_t> mesh_triangles);

/// Calls visit(mesh index, mesh → world) for every mesh placement below group `root` (the world
/// for scene.root), children in order, depth first. Throws mrt::Error naming scene.file on an
/// out-of-range index or a cycle.
void for_each_mesh_instance(const Scene& scene, std::uint32_t root,
                            const std::function<void(std::uint32_t, const Affine3f&)>& visit);

/// Every triangle of the scene in world space, one mesh (instances expanded; per-triangle
/// materials and vertex attributes carried along, normals transformed by the inverse transpose).
Mesh flatten(const Scene& scene);

std::ostream& operator<<(std::ostream& os, const Camera& c);
std::ostream& operator<<(std::ostream& os, const Material& m);

}  // namespace mrt
