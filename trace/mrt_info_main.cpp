// mrt-info: what a .mrh hierarchy file holds — format version, channels present, points and
// triangles per level, bytes per section, build parameters and times.

#include "common/error.h"
#include "common/hierarchy_file.h"
#include "common/tool_main.h"

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <exception>
#include <filesystem>
#include <iostream>
#include <map>

namespace {

int run(const std::filesystem::path& path) {
    const mrt::HierarchyFile file = mrt::HierarchyFile::open(path);
    std::cout << fmt::format("{}: mrtrace hierarchy, format version {}, {} bytes\n", path.string(),
                             file.sections().version(), file.sections().file_size());
    std::cout << fmt::format("grid {}³, {} nodes, {} points, {} triangles, {} vertices\n",
                             file.grid(), file.nodes().size(), file.core().size(),
                             file.triangles().size(), file.vertex_positions().size());
    std::cout << "channels: position normal coverage diffuse";
    if (!file.specular().empty()) {
        std::cout << " specular";
    }
    if (!file.mirror().empty()) {
        std::cout << " reflectivity roughness normal-gradient";
    }
    if (!file.refraction().empty()) {
        std::cout << " transparency ior";
    }
    if (!file.vertex_uvs().empty()) {
        std::cout << " uv";
    }
    std::cout << '\n';
    std::map<int, std::array<std::uint64_t, 3>> levels;  // nodes, points, triangles
    for (const mrt::HierarchyNode& node : file.nodes()) {
        auto& level = levels[node.level];
        level[0] += 1;
        level[1] += node.point_count;
        level[2] += node.triangle_count;
    }
    std::cout << "level     nodes     points  triangles\n";
    for (const auto& [level, counts] : levels) {
        std::cout << fmt::format("{:5} {:9} {:10} {:10}\n", level, counts[0], counts[1], counts[2]);
    }
    std::cout << "section      bytes\n";
    for (const auto& section : file.sections().sections()) {
        std::cout << fmt::format("{:7} {:10}\n", "'" + mrt::tag_name(section.tag) + "'",
                                 section.size);
    }
    std::cout << "build: " << file.build_json() << '\n';
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"mrt-info: describe a .mrh point-hierarchy file", "mrt-info"};
    std::filesystem::path path;
    app.add_option("file", path, "Hierarchy file (.mrh)")->required();
    return mrt::run_tool(app, argc, argv, [&] { return run(path); });
}
