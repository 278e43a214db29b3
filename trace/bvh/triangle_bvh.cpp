#include "trace/bvh/triangle_bvh.h"

#include "trace/bvh/bvh_build.h"
#include "trace/bvh/cutouts.h"
#include "trace/bvh/triangle_intersect.h"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>

#include <emmintrin.h>

namespace mrt {
namespace {

/// SAH constants of the binary build: one packet test (four triangles) costs about as much as a
/// box test; leaves of up to two packets. Measured on the bunny: smaller leaves or costlier
/// packets deepen the tree for no gain, cheaper packets make the leaves too long.
constexpr BvhBuildOptions kTriangleBuildOptions{8, 4, 1.0f, 1.0f};

/// Per-ray constants of both kernels, broadcast for SSE.
struct SimdRay {
    // Slab test: origin and reciprocal direction per axis, and the byte offsets within
    // BvhNode::bounds of each axis' near and far planes (lower first when the direction is
    // positive or zero), so no per-box min/max is needed (Williams et al. 2005, "An Efficient and
    // Robust Ray-Box Intersection Algorithm").
    __m128 org[3];
    __m128 inv[3];
    std::size_t near_offset[3];
    std::size_t far_offset[3];
    // Watertight test: origin components and shear in permuted order.
    int kx, ky, kz;
    __m128 ox, oy, oz;
    __m128 sx, sy, sz;

    explicit SimdRay(const Ray& ray) {
        const SlabRay slab(ray);
        for (int a = 0; a < 3; ++a) {
            org[a] = _mm_set1_ps(slab.origin[a]);
            inv[a] = _mm_set1_ps(slab.inv_dir[a]);
            const std::size_t lower = sizeof(float[4]) * static_cast<std::size_t>(2 * a);
            const bool negative = slab.inv_dir[a] < 0.0f;
            near_offset[a] = negative ? lower + sizeof(float[4]) : lower;
            far_offset[a] = negative ? lower : lower + sizeof(float[4]);
        }
        const WatertightRay w(ray);
        kx = w.kx;
        ky = w.ky;
        kz = w.kz;
        ox = _mm_set1_ps(w.origin[kx]);
        oy = _mm_set1_ps(w.origin[ky]);
        oz = _mm_set1_ps(w.origin[kz]);
        sx = _mm_set1_ps(w.sx);
        sy = _mm_set1_ps(w.sy);
        sz = _mm_set1_ps(w.sz);
    }
};

/// Slab test of a node's four child boxes against [0, t_far]: returns the lanes that overlap,
/// and their entry distances in `near`. With a zero direction component the reciprocal is +inf
/// and a plane through the origin gives 0·inf = NaN; MAXPS/MINPS return their second operand
/// when either is NaN, so the plane distances go first and a NaN constrains nothing (the ray
/// lies in that face plane, and the box counts as entered). Far is widened by kSlabFarScale
/// (Ize 2013) so rounding never loses a box the ray touches.
inline int intersect_node(const BvhNode& node, const SimdRay& r, __m128 t_far, __m128& near) {
    const char* const base = reinterpret_cast<const char*>(node.bounds);
    const auto plane = [&](std::size_t offset, int axis) {
        const __m128 b = _mm_load_ps(reinterpret_cast<const float*>(base + offset));
        return _mm_mul_ps(_mm_sub_ps(b, r.org[axis]), r.inv[axis]);
    };
    near = _mm_max_ps(plane(r.near_offset[2], 2),
                      _mm_max_ps(plane(r.near_offset[1], 1),
                                 _mm_max_ps(plane(r.near_offset[0], 0), _mm_setzero_ps())));
    const __m128 far = _mm_min_ps(
        plane(r.far_offset[2], 2),
        _mm_min_ps(plane(r.far_offset[1], 1), _mm_min_ps(plane(r.far_offset[0], 0), t_far)));
    return _mm_movemask_ps(_mm_cmple_ps(near, _mm_mul_ps(far, _mm_set1_ps(kSlabFarScale))));
}

/// Four-wide intersect_triangle(): the same IEEE operations in the same order per lane, so
/// t and the barycentrics are bit-identical to the scalar reference. Returns the lanes hit with
/// t > 0 and writes t, and the scaled barycentrics v, w and determinant for the caller.
template <typename Packet>
inline int intersect_packet(const Packet& p, const SimdRay& r, __m128& t_out, float v_out[4],
                            float w_out[4], float det_out[4]) {
    const __m128 a_x = _mm_sub_ps(_mm_load_ps(p.v[0][r.kx]), r.ox);
    const __m128 a_y = _mm_sub_ps(_mm_load_ps(p.v[0][r.ky]), r.oy);
    const __m128 a_z = _mm_sub_ps(_mm_load_ps(p.v[0][r.kz]), r.oz);
    const __m128 b_x = _mm_sub_ps(_mm_load_ps(p.v[1][r.kx]), r.ox);
    const __m128 b_y = _mm_sub_ps(_mm_load_ps(p.v[1][r.ky]), r.oy);
    const __m128 b_z = _mm_sub_ps(_mm_load_ps(p.v[1][r.kz]), r.oz);
    const __m128 c_x = _mm_sub_ps(_mm_load_ps(p.v[2][r.kx]), r.ox);
    const __m128 c_y = _mm_sub_ps(_mm_load_ps(p.v[2][r.ky]), r.oy);
    const __m128 c_z = _mm_sub_ps(_mm_load_ps(p.v[2][r.kz]), r.oz);
    const __m128 ax = _mm_sub_ps(a_x, _mm_mul_ps(r.sx, a_z));
    const __m128 ay = _mm_sub_ps(a_y, _mm_mul_ps(r.sy, a_z));
    const __m128 bx = _mm_sub_ps(b_x, _mm_mul_ps(r.sx, b_z));
    const __m128 by = _mm_sub_ps(b_y, _mm_mul_ps(r.sy, b_z));
    const __m128 cx = _mm_sub_ps(c_x, _mm_mul_ps(r.sx, c_z));
    const __m128 cy = _mm_sub_ps(c_y, _mm_mul_ps(r.sy, c_z));
    __m128 u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
    __m128 v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
    __m128 w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
    const __m128 zero = _mm_setzero_ps();
    const __m128 negative =
        _mm_or_ps(_mm_or_ps(_mm_cmplt_ps(u, zero), _mm_cmplt_ps(v, zero)), _mm_cmplt_ps(w, zero));
    const __m128 positive =
        _mm_or_ps(_mm_or_ps(_mm_cmpgt_ps(u, zero), _mm_cmpgt_ps(v, zero)), _mm_cmpgt_ps(w, zero));
    int lanes = ~_mm_movemask_ps(_mm_and_ps(negative, positive)) & 0xf;
    if (lanes == 0) {
        return 0;
    }
    const __m128 on_edge =
        _mm_or_ps(_mm_or_ps(_mm_cmpeq_ps(u, zero), _mm_cmpeq_ps(v, zero)), _mm_cmpeq_ps(w, zero));
    if (const int redo = _mm_movemask_ps(on_edge) & lanes; redo != 0) {
        alignas(16) float s[9][4];
        _mm_store_ps(s[0], ax);
        _mm_store_ps(s[1], ay);
        _mm_store_ps(s[2], bx);
        _mm_store_ps(s[3], by);
        _mm_store_ps(s[4], cx);
        _mm_store_ps(s[5], cy);
        _mm_store_ps(s[6], u);
        _mm_store_ps(s[7], v);
        _mm_store_ps(s[8], w);
        for (int l = 0; l < 4; ++l) {
            if ((redo >> l & 1) != 0) {
                edge_functions_double(s[0][l], s[1][l], s[2][l], s[3][l], s[4][l], s[5][l], s[6][l],
                                      s[7][l], s[8][l]);
                if (edge_signs_differ(s[6][l], s[7][l], s[8][l])) {
                    lanes &= ~(1 << l);
                }
            }
        }
        if (lanes == 0) {
            return 0;
        }
        u = _mm_load_ps(s[6]);
        v = _mm_load_ps(s[7]);
        w = _mm_load_ps(s[8]);
    }
    const __m128 det = _mm_add_ps(_mm_add_ps(u, v), w);
    const __m128 az = _mm_mul_ps(r.sz, a_z);
    const __m128 bz = _mm_mul_ps(r.sz, b_z);
    const __m128 cz = _mm_mul_ps(r.sz, c_z);
    const __m128 t_scaled =
        _mm_add_ps(_mm_add_ps(_mm_mul_ps(u, az), _mm_mul_ps(v, bz)), _mm_mul_ps(w, cz));
    const __m128 t = _mm_div_ps(t_scaled, det);
    lanes &= _mm_movemask_ps(_mm_and_ps(_mm_cmpneq_ps(det, zero), _mm_cmpgt_ps(t, zero)));
    t_out = t;
    if (lanes != 0) {
        _mm_storeu_ps(v_out, v);
        _mm_storeu_ps(w_out, w);
        _mm_storeu_ps(det_out, det);
    }
    return lanes;
}

/// Turns the binary tree into 4-wide nodes: each node takes its binary node's two children and
/// keeps opening the child of largest surface area until it has four (a leaf cannot be opened),
/// which keeps the likeliest-visited boxes together (Wald, Benthin & Boulos 2008, "Getting Rid
/// of Packets").
class Collapser {
  public:
    Collapser(const std::vector<BinaryBvhNode>& binary, const std::vector<std::uint32_t>& packet,
              std::vector<BvhNode>& out)
        : m_binary(binary), m_packet(packet), m_out(out) {}

    /// Emits the 4-wide node for binary inner node `root` and its subtree, depth-first.
    std::uint32_t emit(std::uint32_t root) {
        std::uint32_t children[4];
        int n = 0;
        if (m_binary[root].count != 0) {
            children[n++] = root;  // A tree that is a single leaf: a root with one child.
        } else {
            children[n++] = root + 1;
            children[n++] = m_binary[root].offset;
        }
        while (n < 4) {
            int widest = -1;
            float widest_area = -1.0f;
            for (int i = 0; i < n; ++i) {
                const BinaryBvhNode& c = m_binary[children[i]];
                if (c.count == 0 && half_area(c) > widest_area) {
                    widest = i;
                    widest_area = half_area(c);
                }
            }
            if (widest < 0) {
                break;
            }
            const std::uint32_t opened = children[widest];
            children[widest] = opened + 1;
            children[n++] = m_binary[opened].offset;
        }

        const auto index = static_cast<std::uint32_t>(m_out.size());
        m_out.emplace_back();
        BvhNode node{};
        for (int lane = 0; lane < 4; ++lane) {
            for (int a = 0; a < 3; ++a) {
                node.bounds[2 * a][lane] = kInfinity;
                node.bounds[2 * a + 1][lane] = -kInfinity;
            }
        }
        for (int lane = 0; lane < n; ++lane) {
            const BinaryBvhNode& c = m_binary[children[lane]];
            for (int a = 0; a < 3; ++a) {
                node.bounds[2 * a][lane] = c.lower[a];
                node.bounds[2 * a + 1][lane] = c.upper[a];
            }
            if (c.count != 0) {
                node.child[lane] = m_packet[children[lane]];
                node.count[lane] = c.count;
            } else {
                node.child[lane] = emit(children[lane]);
            }
        }
        m_out[index] = node;
        return index;
    }

  private:
    static float half_area(const BinaryBvhNode& n) {
        const float dx = n.upper[0] - n.lower[0];
        const float dy = n.upper[1] - n.lower[1];
        const float dz = n.upper[2] - n.lower[2];
        return dx * dy + dy * dz + dz * dx;
    }

    const std::vector<BinaryBvhNode>& m_binary;
    const std::vector<std::uint32_t>& m_packet;  ///< Binary leaf → its first packet.
    std::vector<BvhNode>& m_out;
};

}  // namespace

TriangleBvh::TriangleBvh(const Mesh& mesh) {
    const std::size_t n = mesh.triangles.size();
    const std::size_t vertex_count = mesh.positions.size();
    // Triangles with out-of-range indices or non-finite vertices can never be hit sensibly;
    // they are left out rather than poisoning the bounds.
    std::vector<std::uint8_t> valid(n, 0);
    std::vector<Eigen::AlignedBox3f> all_boxes(n);
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, n, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                const auto& tri = mesh.triangles[i];
                if (tri[0] >= vertex_count || tri[1] >= vertex_count || tri[2] >= vertex_count) {
                    continue;
                }
                Eigen::AlignedBox3f box(mesh.positions[tri[0]]);
                box.extend(mesh.positions[tri[1]]);
                box.extend(mesh.positions[tri[2]]);
                if (box.min().allFinite() && box.max().allFinite()) {
                    valid[i] = 1;
                    all_boxes[i] = box;
                }
            }
        });
    std::vector<std::uint32_t> triangle_of_box;
    std::vector<Eigen::AlignedBox3f> boxes;
    triangle_of_box.reserve(n);
    boxes.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        if (valid[i] != 0) {
            triangle_of_box.push_back(static_cast<std::uint32_t>(i));
            boxes.push_back(all_boxes[i]);
        }
    }
    const BvhBuildResult built = build_bvh(boxes, kTriangleBuildOptions);
    if (built.nodes.empty()) {
        return;
    }
    const BinaryBvhNode& root = built.nodes[0];
    m_bounds = Eigen::AlignedBox3f(Vec3f(root.lower[0], root.lower[1], root.lower[2]),
                                   Vec3f(root.upper[0], root.upper[1], root.upper[2]));

    // Binary leaves in depth-first order get consecutive packet runs.
    std::vector<std::uint32_t> leaves;
    std::vector<std::uint32_t> first_packet(built.nodes.size(), 0);
    std::uint32_t packet_count = 0;
    for (std::uint32_t i = 0; i < built.nodes.size(); ++i) {
        if (built.nodes[i].count != 0) {
            leaves.push_back(i);
            first_packet[i] = packet_count;
            packet_count += (built.nodes[i].count + 3u) / 4u;
        }
    }
    m_packets.resize(packet_count);
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, leaves.size(), 256),
        [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t l = r.begin(); l != r.end(); ++l) {
                const BinaryBvhNode& leaf = built.nodes[leaves[l]];
                const std::uint32_t count = leaf.count;
                for (std::uint32_t slot = 0; slot < (count + 3u) / 4u * 4u; ++slot) {
                    const std::uint32_t k = std::min(slot, count - 1);
                    const std::uint32_t triangle =
                        triangle_of_box[built.primitive_order[leaf.offset + k]];
                    TrianglePacket& packet = m_packets[first_packet[leaves[l]] + slot / 4];
                    const std::uint32_t lane = slot % 4;
                    for (int vertex = 0; vertex < 3; ++vertex) {
                        const Vec3f& p = mesh.positions[mesh.triangles[triangle][vertex]];
                        for (int axis = 0; axis < 3; ++axis) {
                            packet.v[vertex][axis][lane] = p[axis];
                        }
                    }
                    packet.index[lane] = triangle;
                }
            }
        });

    // Each 4-wide node but the root holds at least two children, of which at least one leaf
    // or 4-wide node more: fewer nodes than binary leaves.
    m_nodes.reserve(leaves.size());
    Collapser(built.nodes, first_packet, m_nodes).emit(0);
    m_nodes.shrink_to_fit();
}

template <bool kAnyHit, bool kCutout>
bool TriangleBvh::traverse(const Ray& ray, TriangleHit& hit, const MeshCutout* cutout) const {
    // A non-finite origin or direction turns every plane distance into NaN (or an empty lane's
    // +inf·0 into NaN), which the slab test reads as "entered": such a ray would visit the
    // unused lanes too. It cannot hit anything meaningful anyway.
    if (m_nodes.empty() || !ray.origin.allFinite() || !ray.direction.allFinite()) {
        return false;
    }
    const SimdRay r(ray);
    // Closest hit: accept t < t_best, or t == t_best with a lower index than best_index.
    // Starting from ray.t_max with index 0 makes that bound exclusive.
    float t_best = ray.t_max;
    std::uint32_t best_index = 0;
    if constexpr (!kAnyHit) {
        if (hit.t < ray.t_max) {
            t_best = hit.t;
            best_index = hit.triangle;
        }
    }
    bool found = false;
    float best_v = 0.0f, best_w = 0.0f, best_det = 1.0f;

    // A child to visit: node index (count 0) or leaf packets (count triangles), and where the
    // ray enters its box, to skip it once a closer hit is known.
    struct Entry {
        std::uint32_t child;
        std::uint32_t count;
        float t_near;
    };
    // Each level pushes at most three siblings.
    Entry stack[3 * kBvhMaxDepth + 1];
    int top = 0;
    const BvhNode* const nodes = m_nodes.data();
    Entry current{0, 0, 0.0f};
    for (;;) {
        if (current.count == 0) {
            const BvhNode& node = nodes[current.child];
            __m128 near4;
            int mask = intersect_node(node, r, _mm_set1_ps(t_best), near4);
            if (mask != 0) {
                alignas(16) float near[4];
                _mm_store_ps(near, near4);
                const int l0 = std::countr_zero(static_cast<unsigned>(mask));
                mask &= mask - 1;
                if (mask == 0) {
                    current = {node.child[l0], node.count[l0], near[l0]};
                    continue;
                }
                const int l1 = std::countr_zero(static_cast<unsigned>(mask));
                mask &= mask - 1;
                if (mask == 0) {
                    // Nearer child first; the other waits with its entry distance.
                    const int first = near[l1] < near[l0] ? l1 : l0;
                    const int second = l0 + l1 - first;
                    stack[top++] = {node.child[second], node.count[second], near[second]};
                    current = {node.child[first], node.count[first], near[first]};
                    continue;
                }
                // Three or four: push all, sort them far to near (any hit will do for an
                // occlusion query, so it skips that), continue with the nearest.
                const int base = top;
                stack[top++] = {node.child[l0], node.count[l0], near[l0]};
                stack[top++] = {node.child[l1], node.count[l1], near[l1]};
                for (; mask != 0; mask &= mask - 1) {
                    const int l = std::countr_zero(static_cast<unsigned>(mask));
                    stack[top++] = {node.child[l], node.count[l], near[l]};
                }
                if constexpr (!kAnyHit) {
                    for (int i = base + 1; i < top; ++i) {
                        const Entry e = stack[i];
                        int j = i;
                        for (; j > base && stack[j - 1].t_near < e.t_near; --j) {
                            stack[j] = stack[j - 1];
                        }
                        stack[j] = e;
                    }
                }
                current = stack[--top];
                continue;
            }
        } else {
            const TrianglePacket* packet = m_packets.data() + current.child;
            const TrianglePacket* const end = packet + (current.count + 3u) / 4u;
            for (; packet != end; ++packet) {
                __m128 t4;
                alignas(16) float v[4], w[4], det[4];
                int lanes = intersect_packet(*packet, r, t4, v, w, det);
                if (lanes == 0) {
                    continue;
                }
                lanes &= _mm_movemask_ps(_mm_cmple_ps(t4, _mm_set1_ps(t_best)));
                if constexpr (kAnyHit) {
                    // t == t_max is outside the exclusive interval.
                    lanes &= _mm_movemask_ps(_mm_cmplt_ps(t4, _mm_set1_ps(t_best)));
                    if constexpr (kCutout) {
                        for (; lanes != 0; lanes &= lanes - 1) {
                            const int l = std::countr_zero(static_cast<unsigned>(lanes));
                            if (cutout->stands(packet->index[l], v[l] / det[l], w[l] / det[l])) {
                                return true;
                            }
                        }
                    }
                    if (lanes != 0) {
                        return true;
                    }
                } else {
                    alignas(16) float t[4];
                    _mm_store_ps(t, t4);
                    for (; lanes != 0; lanes &= lanes - 1) {
                        const int l = std::countr_zero(static_cast<unsigned>(lanes));
                        const std::uint32_t index = packet->index[l];
                        if ((t[l] < t_best || (t[l] == t_best && index < best_index)) &&
                            (!kCutout || cutout->stands(index, v[l] / det[l], w[l] / det[l]))) {
                            t_best = t[l];
                            best_index = index;
                            best_v = v[l];
                            best_w = w[l];
                            best_det = det[l];
                            found = true;
                        }
                    }
                }
            }
        }
        // Pop the next subtree that may still hold something closer than the best hit.
        const float t_limit = t_best * kSlabFarScale;
        for (;;) {
            if (top == 0) {
                if constexpr (!kAnyHit) {
                    if (found) {
                        hit.t = t_best;
                        hit.triangle = best_index;
                        hit.b1 = best_v / best_det;
                        hit.b2 = best_w / best_det;
                    }
                }
                return found;
            }
            current = stack[--top];
            if (current.t_near <= t_limit) {
                break;
            }
        }
    }
}

bool TriangleBvh::intersect(const Ray& ray, TriangleHit& hit, const MeshCutout* cutout) const {
    return cutout != nullptr ? traverse<false, true>(ray, hit, cutout)
                             : traverse<false, false>(ray, hit, nullptr);
}

bool TriangleBvh::occluded(const Ray& ray, const MeshCutout* cutout) const {
    TriangleHit unused;
    return cutout != nullptr ? traverse<true, true>(ray, unused, cutout)
                             : traverse<true, false>(ray, unused, nullptr);
}

Eigen::AlignedBox3f TriangleBvh::bounds() const {
    return m_bounds;
}

std::size_t TriangleBvh::bytes() const {
    return sizeof(*this) + m_nodes.capacity() * sizeof(BvhNode) +
           m_packets.capacity() * sizeof(TrianglePacket);
}

}  // namespace mrt
