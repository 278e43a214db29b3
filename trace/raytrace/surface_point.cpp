#include "trace/raytrace/surface_point.h"

#include "common/math/invertibility.h"

namespace mrt {

SurfacePoint make_surface_point(const Scene& scene, const SceneHit& hit, const Vec3f& direction) {
    const Mesh& mesh = scene.meshes[hit.mesh];
    const auto& tri = mesh.triangles[hit.triangle];
    const float b0 = 1.0f - hit.b1 - hit.b2;
    const Vec3f& p0 = mesh.positions[tri[0]];
    const Vec3f& p1 = mesh.positions[tri[1]];
    const Vec3f& p2 = mesh.positions[tri[2]];
    const Vec3f object_position = b0 * p0 + hit.b1 * p1 + hit.b2 * p2;

    SurfacePoint sp;
    sp.material = mesh.materials[hit.triangle];
    const auto linear = hit.object_to_world.linear();
    // Normals transform by the inverse transpose, taken in double: in float the determinant of
    // an accepted scale of 1e13 overflows, and of 1e-30 underflows.
    sp.normal_matrix = inverse_in_double(Mat3f(linear)).transpose();
    const Mat3f& normal_matrix = sp.normal_matrix;
    sp.position = hit.object_to_world * object_position;
    const float vertex_magnitude =
        std::max({p0.cwiseAbs().maxCoeff(), p1.cwiseAbs().maxCoeff(), p2.cwiseAbs().maxCoeff()});
    // Error of the barycentric sum in object space, carried through the transform by its norm,
    // plus the transform's own rounding at the world point's magnitude.
    const float object_error = intersection_error_bound(object_position, vertex_magnitude);
    sp.error_bound = object_error * linear.cwiseAbs().rowwise().sum().maxCoeff() +
                     intersection_error_bound(sp.position, 0.0f);

    Vec3f ng = normal_matrix * (p1 - p0).cross(p2 - p0);
    const float ng_norm = ng.norm();
    ng = ng_norm > 0.0f && std::isfinite(ng_norm) ? Vec3f(ng / ng_norm) : Vec3f(0.0f, 0.0f, 1.0f);
    Vec3f ns = normal_matrix * (b0 * mesh.normals[tri[0]] + hit.b1 * mesh.normals[tri[1]] +
                                hit.b2 * mesh.normals[tri[2]]);
    const float ns_norm = ns.norm();
    ns = ns_norm > 0.0f && std::isfinite(ns_norm) ? Vec3f(ns / ns_norm) : ng;

    sp.entering = ng.dot(direction) < 0.0f;
    if (!sp.entering) {
        ng = -ng;
        ns = -ns;
    }
    sp.geometric_normal = ng;
    sp.shading_normal = ns;
    if (mesh.has_uvs()) {
        sp.has_uv = true;
        sp.uv = b0 * mesh.uvs[tri[0]] + hit.b1 * mesh.uvs[tri[1]] + hit.b2 * mesh.uvs[tri[2]];
    }
    return sp;
}

SurfaceDifferential make_surface_differential(const Scene& scene, const SceneHit& hit,
                                              const SurfacePoint& sp, const Vec3f& dp_dx,
                                              const Vec3f& dp_dy) {
    const Mesh& mesh = scene.meshes[hit.mesh];
    const auto& tri = mesh.triangles[hit.triangle];
    // The derivatives depend on the edges only, so the vertices are taken relative to the
    // first one in object space and the edges mapped by the transform's linear part: world
    // coordinates far from the origin would round small edges (dN off by percent at 1e5).
    const Vec3f& origin = mesh.positions[tri[0]];
    const auto linear = hit.object_to_world.linear();
    Vec3f p[3];
    Vec3f n[3];
    Vec2f uv[3];
    for (int i = 0; i < 3; ++i) {
        p[i] = linear * (mesh.positions[tri[static_cast<std::size_t>(i)]] - origin);
        n[i] = sp.normal_matrix * mesh.normals[tri[static_cast<std::size_t>(i)]];
        uv[i] = mesh.has_uvs() ? mesh.uvs[tri[static_cast<std::size_t>(i)]] : Vec2f::Zero();
    }
    return triangle_differential(p, n, uv, hit.b1, hit.b2, dp_dx, dp_dy,
                                 sp.entering ? Facing::Front : Facing::Back);
}

}  // namespace mrt
