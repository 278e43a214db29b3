// OpenMesh side of the mesh loader: OpenMesh is included here and nowhere else.

#include "common/mesh/openmesh_import.h"
#include "common/system/error.h"

#include <fmt/format.h>
#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <limits>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <utility>

namespace mrt::mesh_io {

namespace fs = std::filesystem;
namespace om = OpenMesh;

namespace {

/// Collects what OpenMesh's readers deliver as a plain polygon soup. A TriMesh would be the
/// obvious target, but its importer silently drops faces with invalid or repeated indices,
/// duplicates vertices around non-manifold edges (tearing smooth normals apart), and assigns
/// per-corner texture coordinates of polygons to the wrong halfedges once it has triangulated
/// them. Here every face arrives as written, and bad indices are recorded, not skipped.
class SoupImporter final : public om::IO::BaseImporter {
  public:
    /// `capacity` bounds how many vertices and corners a file of that many bytes can hold, so
    /// that a reader looping on a lying header cannot exhaust memory.
    explicit SoupImporter(std::size_t capacity) : capacity_(capacity) {}

    PolygonSoup soup;  ///< What has been read; its has_normals and has_uvs are left to the caller.
    bool got_normals = false;
    bool got_uvs = false;
    std::optional<std::pair<std::string, std::string>> error;  ///< First (location, message).

    om::VertexHandle add_vertex(const om::Vec3f& p) override {
        return append_vertex(Vec3f(p[0], p[1], p[2]));
    }
    om::VertexHandle add_vertex(const om::Vec3d& p) override {
        const auto to_float = [](double v) {
            return finite_as_float(v) ? static_cast<float>(v)
                                      : std::numeric_limits<float>::infinity();
        };
        return append_vertex(Vec3f(to_float(p[0]), to_float(p[1]), to_float(p[2])));
    }
    om::VertexHandle add_vertex() override { return append_vertex(Vec3f::Zero()); }

    void set_point(om::VertexHandle vh, const om::Vec3f& p) override {
        if (valid(vh)) {
            soup.positions[static_cast<std::size_t>(vh.idx())] = Vec3f(p[0], p[1], p[2]);
        }
    }

    om::FaceHandle add_face(const VHandles& indices) override {
        const om::FaceHandle refused;
        const std::size_t face = soup.face_total();
        if (error) {
            return refused;
        }
        for (const om::VertexHandle vh : indices) {
            if (!valid(vh)) {
                record_error(fmt::format("face {}", face),
                             fmt::format("refers to vertex {} but the file has {} vertices",
                                         vh.idx(), soup.positions.size()));
                return refused;
            }
        }
        if (soup.face_total() >= capacity_ || soup.corners.size() + indices.size() > capacity_) {
            record_error("", "more face corners than the file's size allows (corrupt header?)");
            return refused;
        }
        for (const om::VertexHandle vh : indices) {
            const auto v = static_cast<std::size_t>(vh.idx());
            soup.corners.push_back(
                {static_cast<std::uint32_t>(v), soup.vertex_uvs[v], soup.vertex_normals[v]});
        }
        soup.face_starts.push_back(soup.corners.size());
        return om::FaceHandle(static_cast<int>(face));
    }

    void set_normal(om::VertexHandle vh, const om::Vec3f& n) override {
        if (valid(vh)) {
            soup.vertex_normals[static_cast<std::size_t>(vh.idx())] = Vec3f(n[0], n[1], n[2]);
            got_normals = true;
        }
    }
    void set_normal(om::VertexHandle vh, const om::Vec3d& n) override {
        set_normal(vh, om::Vec3f(static_cast<float>(n[0]), static_cast<float>(n[1]),
                                 static_cast<float>(n[2])));
    }
    void set_texcoord(om::VertexHandle vh, const om::Vec2f& t) override {
        if (valid(vh)) {
            soup.vertex_uvs[static_cast<std::size_t>(vh.idx())] = Vec2f(t[0], t[1]);
            got_uvs = true;
        }
    }

    std::size_t n_vertices() const override { return soup.positions.size(); }
    std::size_t n_faces() const override { return soup.face_total(); }
    std::size_t n_edges() const override { return 0; }

    // Everything below carries information a triangle soup for rendering does not use (colors,
    // status flags, face normals, material names) or belongs to OpenMesh's own .om format, which
    // writes connectivity directly.
    om::HalfedgeHandle add_edge(om::VertexHandle, om::VertexHandle) override {
        return om::HalfedgeHandle();
    }
    om::FaceHandle add_face(om::HalfedgeHandle) override { return om::FaceHandle(); }
    void add_face_texcoords(om::FaceHandle, om::VertexHandle,
                            const std::vector<om::Vec2f>&) override {}
    void add_face_texcoords(om::FaceHandle, om::VertexHandle,
                            const std::vector<om::Vec3f>&) override {}
    void set_face_texindex(om::FaceHandle, int) override {}
    void set_halfedge(om::VertexHandle, om::HalfedgeHandle) override {}
    void set_color(om::VertexHandle, const om::Vec3uc&) override {}
    void set_color(om::VertexHandle, const om::Vec4uc&) override {}
    void set_color(om::VertexHandle, const om::Vec3f&) override {}
    void set_color(om::VertexHandle, const om::Vec4f&) override {}
    void set_status(om::VertexHandle, const om::Attributes::StatusInfo&) override {}
    void set_next(om::HalfedgeHandle, om::HalfedgeHandle) override {}
    void set_face(om::HalfedgeHandle, om::FaceHandle) override {}
    void request_face_texcoords2D() override {}
    void set_texcoord(om::HalfedgeHandle, const om::Vec2f&) override {}
    void set_texcoord(om::VertexHandle, const om::Vec3f&) override {}
    void set_texcoord(om::HalfedgeHandle, const om::Vec3f&) override {}
    void set_status(om::HalfedgeHandle, const om::Attributes::StatusInfo&) override {}
    void set_color(om::EdgeHandle, const om::Vec3uc&) override {}
    void set_color(om::EdgeHandle, const om::Vec4uc&) override {}
    void set_color(om::EdgeHandle, const om::Vec3f&) override {}
    void set_color(om::EdgeHandle, const om::Vec4f&) override {}
    void set_status(om::EdgeHandle, const om::Attributes::StatusInfo&) override {}
    void set_normal(om::FaceHandle, const om::Vec3f&) override {}
    void set_normal(om::FaceHandle, const om::Vec3d&) override {}
    void set_color(om::FaceHandle, const om::Vec3uc&) override {}
    void set_color(om::FaceHandle, const om::Vec4uc&) override {}
    void set_color(om::FaceHandle, const om::Vec3f&) override {}
    void set_color(om::FaceHandle, const om::Vec4f&) override {}
    void set_status(om::FaceHandle, const om::Attributes::StatusInfo&) override {}
    void add_texture_information(int, std::string) override {}

  private:
    om::VertexHandle append_vertex(const Vec3f& p) {
        if (soup.positions.size() >= capacity_) {
            record_error("", "more vertices than the file's size allows (corrupt header?)");
            return om::VertexHandle();
        }
        soup.positions.push_back(p);
        soup.vertex_normals.push_back(kNoNormal);
        soup.vertex_uvs.push_back(kNoUv);
        return om::VertexHandle(static_cast<int>(soup.positions.size() - 1));
    }
    bool valid(om::VertexHandle vh) const {
        return vh.idx() >= 0 && static_cast<std::size_t>(vh.idx()) < soup.positions.size();
    }
    void record_error(std::string location, std::string message) {
        if (!error) {
            error.emplace(std::move(location), std::move(message));
        }
    }

    std::size_t capacity_;
};

std::mutex& openmesh_mutex() {
    static std::mutex mutex;
    return mutex;
}

/// OpenMesh's omerr/omlog/omout default to cerr/clog/cout; their multi-line chatter must not
/// reach the user, but can explain a failure. Their stream buffer is replaced, once for the whole
/// program (OpenMesh is used nowhere else), by this one, which each read clears and inspects
/// under openmesh_mutex(). (mostream::disconnect would leak the target wrapper it allocated.)
std::stringbuf& openmesh_log() {
    // Never destroyed, so that OpenMesh's own static streams may outlive it safely.
    static std::stringbuf* const log = [] {
        auto* const buffer = new std::stringbuf;
        for (om::mostream* const stream : {&omerr(), &omlog(), &omout()}) {
            stream->flush();
            stream->rdbuf(buffer);
        }
        return buffer;
    }();
    return *log;
}

/// The first non-empty line of `log`.
std::string first_line(const std::stringbuf& log) {
    std::istringstream lines(log.str());
    std::string line;
    while (std::getline(lines, line)) {
        const std::string_view t = trim(line);
        if (!t.empty()) {
            return std::string(t);
        }
    }
    return {};
}

}  // namespace

PolygonSoup read_with_openmesh(const fs::path& file, Format format, const ScanResult& scan,
                               std::size_t file_size) {
    SoupImporter importer(file_size);
    // OBJ attributes come from the scan (see ObjScan), so OpenMesh need not read them.
    om::IO::Options options;
    if (format != Format::obj) {
        options += om::IO::Options::VertexNormal;
        options += om::IO::Options::VertexTexCoord;
    }
    bool read_ok = false;
    std::string diagnostics;
    {
        // OpenMesh's readers are global singletons with per-read state, and its log streams
        // are global too.
        const std::lock_guard lock(openmesh_mutex());
        std::stringbuf& log = openmesh_log();
        log.str("");
        read_ok = om::IO::IOManager().read(file.string(), importer, options);
        diagnostics = first_line(log);
        log.str("");
    }
    PolygonSoup& soup = importer.soup;
    const std::string explanation = diagnostics.empty() ? "" : " (OpenMesh: " + diagnostics + ")";
    if (importer.error) {
        throw Error(file, importer.error->first, importer.error->second);
    }
    if (!read_ok) {
        throw Error(file, "",
                    fmt::format("not a readable {} file{}", format_name(format), explanation));
    }
    if (scan.vertices && soup.positions.size() != *scan.vertices) {
        throw Error(file, "",
                    fmt::format("OpenMesh read {} of the {} vertices in the file{}",
                                soup.positions.size(), *scan.vertices, explanation));
    }
    if (scan.faces && soup.face_total() != *scan.faces) {
        throw Error(file, "",
                    fmt::format("OpenMesh read {} of the {} faces in the file{}", soup.face_total(),
                                *scan.faces, explanation));
    }
    for (std::size_t v = 0; v < soup.positions.size(); ++v) {
        const Vec3f& p = soup.positions[v];
        if (!all_finite(p)) {
            throw Error(file, "",
                        fmt::format("vertex {} has a non-finite coordinate ({} {} {})", v, p.x(),
                                    p.y(), p.z()));
        }
    }
    soup.has_normals = importer.got_normals && options.vertex_has_normal();
    soup.has_uvs = importer.got_uvs && options.vertex_has_texcoord();
    return std::move(importer.soup);
}

}  // namespace mrt::mesh_io
