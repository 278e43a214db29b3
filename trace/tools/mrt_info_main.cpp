// mrt-info: what a .mrh hierarchy file holds — format version, channels present, points and
// triangles per level, bytes per section, build parameters.

#include "common/cli/tool_main.h"
#include "common/hierarchy/hierarchy_file.h"
#include "common/hierarchy/hierarchy_summary.h"
#include "common/system/error.h"

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <exception>
#include <filesystem>
#include <iostream>

namespace {

int run(const std::filesystem::path& path) {
    mrt::set_activity("reading " + path.string());
    const mrt::HierarchyFile file = mrt::HierarchyFile::open(path);
    std::cout << fmt::format("{}: mrtrace hierarchy, format version {}, {} bytes\n", path.string(),
                             file.sections().version(), file.sections().file_size());
    std::cout << mrt::hierarchy_summary(file);
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
