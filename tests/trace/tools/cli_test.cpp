// mrt-trace as a user meets it: exit codes, one-line messages naming the file, and the stats
// JSON contract.

#include "common/cli/tool_main.h"
#include "common/hierarchy/hierarchy_file.h"
#include "common/hierarchy/section_file.h"
#include "common/image/image.h"
#include "common/scene_io/scene_loader.h"
#include "common/system/error.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <new>
#include <sstream>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

namespace {

namespace fs = std::filesystem;

struct TraceRun {
    int exit_code;
    std::string output;  ///< stdout and stderr together
};

/// Runs `exe` with `arguments` through the shell: its exit code and its stdout and stderr.
TraceRun run_tool(const char* exe, const std::string& arguments) {
    const std::string command = std::string(exe) + " " + arguments + " 2>&1";
    FILE* pipe = popen(command.c_str(), "r");
    if (pipe == nullptr) {
        return {-1, "popen failed"};
    }
    std::string output;
    std::array<char, 4096> buffer{};
    while (fgets(buffer.data(), static_cast<int>(buffer.size()), pipe) != nullptr) {
        output += buffer.data();
    }
    const int status = pclose(pipe);
    return {WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status), output};
}

TraceRun run_trace(const std::string& arguments) {
    return run_tool(MRT_TRACE_EXE, arguments);
}

fs::path temp_dir() {
    const fs::path dir =
        fs::temp_directory_path() /
        ("mrt_cli_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir);
    return dir;
}

std::string scene_path() {
    return std::string(MRT_SOURCE_DIR) + "/data/scenes/two-spheres.json";
}

int count_lines(const std::string& s) {
    return static_cast<int>(std::count(s.begin(), s.end(), '\n'));
}

TEST(MrtTraceCli, RendersAndWritesTheStatsContract) {
    const fs::path dir = temp_dir();
    const TraceRun run =
        run_trace(scene_path() + " -o " + (dir / "out.png").string() +
                  " --width 32 --height 24 --threads 2 --stats " + (dir / "stats.json").string());
    ASSERT_EQ(run.exit_code, 0) << run.output;
    EXPECT_TRUE(run.output.empty()) << "not a terminal, so silent: " << run.output;
    EXPECT_TRUE(fs::exists(dir / "out.png"));
    std::ifstream in(dir / "stats.json");
    const nlohmann::json stats = nlohmann::json::parse(in);
    for (const char* key : {"load_seconds", "build_seconds", "render_seconds", "rays",
                            "rays_per_second", "peak_rss_bytes"}) {
        EXPECT_TRUE(stats.contains(key)) << key;
    }
    EXPECT_EQ(stats["width"], 32);
    EXPECT_EQ(stats["height"], 24);
    EXPECT_GE(stats["rays"].get<std::uint64_t>(), 32u * 24u);
    EXPECT_GT(stats["peak_rss_bytes"].get<std::uint64_t>(), 0u);
    fs::remove_all(dir);
}

/// `mrt-trace mesh.obj -o out.png` and `mrt-preprocess mesh.obj` work without a scene file;
/// --print-scene prints the scene they stand for, which saved and loaded renders the same image.
TEST(MrtTraceCli, LooksAtAMeshFileInOneCommandAndPrintsItsScene) {
    const fs::path dir = temp_dir();
    std::ofstream(dir / "solid.obj") << "v 0 0 0\nv 1.2 0 0.1\nv 0.3 0 1\nv 0.5 1.4 0.4\n"
                                        "f 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n";
    const std::string size = " --width 32 --height 24 --threads 2";
    const fs::path mesh = dir / "solid.obj";
    const TraceRun looked = run_trace(mesh.string() + " -o " + (dir / "mesh.exr").string() + size);
    ASSERT_EQ(looked.exit_code, 0) << looked.output;

    const TraceRun printed = run_trace(mesh.string() + " --print-scene");
    ASSERT_EQ(printed.exit_code, 0) << printed.output;
    const nlohmann::json scene = nlohmann::json::parse(printed.output);
    EXPECT_TRUE(scene.contains("camera") && scene.contains("lights") && scene.contains("objects"));
    EXPECT_EQ(scene["objects"][0]["file"], fs::absolute(mesh).string());
    std::ofstream(dir / "saved.json") << printed.output;
    const TraceRun saved =
        run_trace((dir / "saved.json").string() + " -o " + (dir / "saved.exr").string() + size);
    ASSERT_EQ(saved.exit_code, 0) << saved.output;
    const mrt::Image a = mrt::read_image(dir / "mesh.exr");
    const mrt::Image b = mrt::read_image(dir / "saved.exr");
    ASSERT_EQ(a.data().size(), b.data().size());
    EXPECT_TRUE(std::equal(a.data().begin(), a.data().end(), b.data().begin()));

    // Without an image to write and without --print-scene: one line saying so.
    const TraceRun no_output = run_trace(mesh.string());
    EXPECT_EQ(no_output.exit_code, 1);
    EXPECT_EQ(count_lines(no_output.output), 1) << no_output.output;
    EXPECT_NE(no_output.output.find("--output"), std::string::npos) << no_output.output;

    // mrt-preprocess writes the mesh's name with .mrh in the working directory.
    const TraceRun preprocessed =
        run_tool(("cd " + dir.string() + " && " + MRT_PREPROCESS_EXE).c_str(), "solid.obj");
    ASSERT_EQ(preprocessed.exit_code, 0) << preprocessed.output;
    ASSERT_TRUE(fs::exists(dir / "solid.mrh"));
    const TraceRun cone = run_trace((dir / "solid.mrh").string() + " --method cone -o " +
                                    (dir / "cone.exr").string() + size);
    EXPECT_EQ(cone.exit_code, 0) << cone.output;
    fs::remove_all(dir);
}

TEST(MrtTraceCli, MissingSceneIsOneLineNamingTheFile) {
    const fs::path dir = temp_dir();
    const TraceRun run =
        run_trace((dir / "nope.json").string() + " -o " + (dir / "x.png").string());
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(count_lines(run.output), 1) << run.output;
    EXPECT_NE(run.output.find("nope.json"), std::string::npos) << run.output;
    EXPECT_FALSE(fs::exists(dir / "x.png"));
    fs::remove_all(dir);
}

TEST(MrtTraceCli, BrokenSceneNamesFileAndPosition) {
    const fs::path dir = temp_dir();
    { std::ofstream(dir / "broken.json") << "{\n  \"camera\": {\n    \"eye\": [0, 1,,]\n"; }
    const TraceRun run =
        run_trace((dir / "broken.json").string() + " -o " + (dir / "x.png").string());
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(count_lines(run.output), 1) << run.output;
    EXPECT_NE(run.output.find("broken.json"), std::string::npos) << run.output;
    EXPECT_NE(run.output.find("line 3"), std::string::npos) << run.output;
    EXPECT_FALSE(fs::exists(dir / "x.png"));
    fs::remove_all(dir);
}

TEST(MrtTraceCli, BadCommandLinesExitWithUsageCode) {
    EXPECT_EQ(run_trace("").exit_code, 2);
    EXPECT_EQ(run_trace(scene_path() + " -o x.png --method nonsense").exit_code, 2);
    EXPECT_EQ(run_trace(scene_path() + " -o x.png --spp 0").exit_code, 2);
    EXPECT_EQ(run_trace(scene_path() + " -o x.png --bogus").exit_code, 2);
    const TraceRun help = run_trace("--help");
    EXPECT_EQ(help.exit_code, 0);
    EXPECT_NE(help.output.find("--spp"), std::string::npos);
}

TEST(MrtTraceCli, UnwritableOutputFailsCleanly) {
    const TraceRun run = run_trace(scene_path() + " -o /nonexistent-dir/x.png --width 8");
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(count_lines(run.output), 1) << run.output;
    EXPECT_NE(run.output.find("x.png"), std::string::npos) << run.output;
}

TEST(MrtTraceCli, UnknownOutputExtensionIsRefused) {
    const fs::path dir = temp_dir();
    const TraceRun run =
        run_trace(scene_path() + " -o " + (dir / "x.bmpx").string() + " --width 8");
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_NE(run.output.find("x.bmpx"), std::string::npos) << run.output;
    fs::remove_all(dir);
}

nlohmann::json read_json(const fs::path& file) {
    std::ifstream in(file);
    return nlohmann::json::parse(in);
}

TEST(MrtTraceCli, DistributedReferenceReportsItsStandardError) {
    const fs::path dir = temp_dir();
    const TraceRun run = run_trace(scene_path() + " -o " + (dir / "ref.exr").string() +
                                   " --method distributed --reference --spp 16 --width 24 "
                                   "--height 16 --filter gaussian:0.75 --stats " +
                                   (dir / "stats.json").string());
    ASSERT_EQ(run.exit_code, 0) << run.output;
    const nlohmann::json stats = read_json(dir / "stats.json");
    EXPECT_EQ(stats["method"], "distributed");
    EXPECT_EQ(stats["filter"], "gaussian:0.75");
    EXPECT_EQ(stats["spp"], 16);
    EXPECT_EQ(stats["passes"], 8);
    EXPECT_EQ(stats["samples"], 16 * 24 * 16);
    EXPECT_DOUBLE_EQ(stats["mean_spp"].get<double>(), 16.0);
    ASSERT_TRUE(stats["std_error"].is_number());
    EXPECT_GT(stats["std_error"].get<double>(), 0.0);
    fs::remove_all(dir);
}

TEST(MrtTraceCli, AdaptiveDistributedStatsAndWhittedHasNoStandardError) {
    const fs::path dir = temp_dir();
    TraceRun run = run_trace(scene_path() + " -o " + (dir / "d.png").string() +
                             " --method distributed --spp-initial 1 --spp-max 8 --width 24 "
                             "--height 16 --stats " +
                             (dir / "d.json").string());
    ASSERT_EQ(run.exit_code, 0) << run.output;
    nlohmann::json stats = read_json(dir / "d.json");
    EXPECT_EQ(stats["passes"], 2);
    EXPECT_EQ(stats["spp"], 8);
    EXPECT_GE(stats["mean_spp"].get<double>(), 1.0);
    EXPECT_LE(stats["mean_spp"].get<double>(), 8.0);
    EXPECT_TRUE(stats["std_error"].is_null());
    EXPECT_TRUE(stats["time_budget"].is_null());

    run = run_trace(scene_path() + " -o " + (dir / "w.png").string() +
                    " --width 24 --height 16 --stats " + (dir / "w.json").string());
    ASSERT_EQ(run.exit_code, 0) << run.output;
    stats = read_json(dir / "w.json");
    EXPECT_EQ(stats["filter"], "box");
    EXPECT_EQ(stats["passes"], 1);
    EXPECT_EQ(stats["samples"], 24 * 16);
    EXPECT_TRUE(stats["std_error"].is_null());
    fs::remove_all(dir);
}

TEST(MrtTraceCli, OptionsAMethodDoesNotReadAreRefused) {
    const std::string base = scene_path() + " -o x.png --width 8 ";
    for (const char* args :
         {"--reference", "--spp-max 4", "--spp-initial 2", "--target-error 0.1"}) {
        const TraceRun run = run_trace(base + args);
        EXPECT_EQ(run.exit_code, 2) << args;
        EXPECT_NE(run.output.find("only the distributed method"), std::string::npos) << run.output;
        EXPECT_EQ(count_lines(run.output), 1) << run.output;
    }
    {
        const TraceRun run = run_trace(base + "--time-budget 1");
        EXPECT_EQ(run.exit_code, 2);
        EXPECT_NE(run.output.find("only the distributed and the cone methods"), std::string::npos)
            << run.output;
    }
    // The cone methods' own options, and what they refuse.
    for (const char* args : {"--max-anisotropy 4", "--no-level-blend", "--node-frames",
                             "--triangle-weight paper", "--abuffer mask"}) {
        const TraceRun run = run_trace(base + args);
        EXPECT_EQ(run.exit_code, 2) << args;
        EXPECT_NE(run.output.find("only the cone methods"), std::string::npos) << run.output;
    }
    {
        const TraceRun run = run_trace(base + "--method cone --spp 4");
        EXPECT_EQ(run.exit_code, 2);
        EXPECT_NE(run.output.find("one cone per pixel"), std::string::npos) << run.output;
    }
    const std::string distributed = base + "--method distributed ";
    EXPECT_EQ(run_trace(distributed + "--reference --time-budget 1").exit_code, 2);
    EXPECT_EQ(run_trace(distributed + "--spp 4 --spp-max 8").exit_code, 2);
    EXPECT_EQ(run_trace(distributed + "--spp-initial 8 --spp-max 4").exit_code, 2);
    EXPECT_EQ(run_trace(distributed + "--time-budget 0").exit_code, 2);
    EXPECT_EQ(run_trace(base + "--filter gaussian:0").exit_code, 2);
    EXPECT_EQ(run_trace(base + "--filter tent").exit_code, 2);
}

TEST(MrtTraceCli, CropIsAWindowOfTheFrameAndItsMistakesAreNamed) {
    const fs::path dir = temp_dir();
    const std::string base =
        scene_path() + " --width 32 --height 24 --threads 2 -o " + (dir / "x.exr").string() + " ";
    for (const char* crop : {"0,0,33,24", "8,8,8,12", "-1,0,4,4", "1,2,3", "a,b,c,d", "0,0,4,4,"}) {
        const TraceRun run = run_trace(base + "--crop " + crop);
        EXPECT_NE(run.exit_code, 0) << crop;
        EXPECT_NE(run.output.find("--crop"), std::string::npos) << run.output;
        EXPECT_EQ(count_lines(run.output), 1) << run.output;
    }
    const TraceRun run =
        run_trace(base + "--crop 4,2,20,14 --stats " + (dir / "stats.json").string());
    ASSERT_EQ(run.exit_code, 0) << run.output;
    const nlohmann::json stats = nlohmann::json::parse(std::ifstream(dir / "stats.json"));
    EXPECT_EQ(stats["width"], 32);
    EXPECT_EQ(stats["crop"], nlohmann::json::array({4, 2, 20, 14}));
}

TEST(MrtTraceCli, CropsPastedByOiiotoolAreTheFullFrame) {
    // The commands of docs/scaling.md: four windows rendered apart, pasted by
    // scripts/paste-tiles (oiiotool).
    if (std::system("oiiotool --version > /dev/null 2>&1") != 0) {
        GTEST_SKIP() << "oiiotool is not installed";
    }
    const fs::path dir = temp_dir();
    const std::string base = scene_path() + " --width 32 --height 24 --method distributed " +
                             "--spp-max 8 --filter gaussian:1 --threads 2 -q ";
    ASSERT_EQ(run_trace(base + "-o " + (dir / "full.exr").string()).exit_code, 0);
    fs::create_directories(dir / "tiles");
    for (const auto& [x0, y0] :
         {std::pair{0, 0}, std::pair{16, 0}, std::pair{0, 12}, std::pair{16, 12}}) {
        const std::string tile =
            (dir / "tiles" / ("tile-" + std::to_string(x0) + "-" + std::to_string(y0) + ".exr"))
                .string();
        const std::string crop = std::to_string(x0) + "," + std::to_string(y0) + "," +
                                 std::to_string(x0 + 16) + "," + std::to_string(y0 + 12);
        ASSERT_EQ(run_trace(base + "--crop " + crop + " -o " + tile).exit_code, 0);
    }
    const std::string paste = std::string(MRT_SOURCE_DIR) + "/scripts/paste-tiles 32 24 " +
                              (dir / "tiles").string() + " " + (dir / "pasted.exr").string();
    ASSERT_EQ(std::system(paste.c_str()), 0) << paste;
    // --fail 0: any difference at all fails.
    const std::string diff = "oiiotool --fail 0 --failpercent 0 " + (dir / "full.exr").string() +
                             " " + (dir / "pasted.exr").string() + " --diff > /dev/null";
    EXPECT_EQ(std::system(diff.c_str()), 0) << diff;
}

// ---- Hostile scenes and the --budget option ---------------------------------------------------

/// A small scene: `objects` under the camera of `resolution`, and `groups`.
std::string small_scene(const std::string& objects, const std::string& groups = "{}",
                        const std::string& resolution = "[16, 16]") {
    return R"({"camera": {"eye": [0, 2, 6], "look_at": [0, 0, 0], "resolution": )" + resolution +
           R"(}, "materials": {"grey": {}}, "lights": [{"type": "point", "position": [0, 5, 5],)"
           R"( "intensity": 20}], "groups": )" +
           groups + R"(, "objects": )" + objects + "}";
}

constexpr const char* kQuad = R"({"shape": "quad", "size": [4, 4], "material": "grey"})";

/// g1 … gN, each instancing the next, gN a quad; the world instances g1: N + 1 levels.
std::string chain_scene(int n) {
    std::string groups = "{";
    for (int k = 1; k <= n; ++k) {
        groups += (k > 1 ? ", " : "") + ("\"g" + std::to_string(k) + "\": {\"objects\": [") +
                  (k < n ? "{\"instance\": \"g" + std::to_string(k + 1) + "\"}" : kQuad) + "]}";
    }
    return small_scene(R"([{"instance": "g1"}])", groups + "}");
}

fs::path write_file(const fs::path& file, const std::string& text) {
    std::ofstream(file, std::ios::binary) << text;
    return file;
}

TEST(MrtTraceCli, EveryBudgetAssignmentApplies) {
    const fs::path dir = temp_dir();
    // 20000² pixels are over the default budget, two quads over a budget of one instance.
    const fs::path scene = write_file(
        dir / "two.json",
        small_scene("[" + std::string(kQuad) + ", " + kQuad + "]", "{}", "[20000, 20000]"));
    const std::string base =
        scene.string() + " -o " + (dir / "x.png").string() + " --width 8 --height 8 ";
    TraceRun run = run_trace(base);
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.output, "mrt-trace: " + scene.string() +
                              ": /camera/resolution: the scene asks for 4e+08 pixels (camera "
                              "resolution), over the limit of 2.68e+08 (raise it with --budget "
                              "pixels=N)\n");
    run = run_trace(base + "--budget pixels=4e8 --budget instances=1");
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.output, "mrt-trace: " + scene.string() +
                              ": /objects: the scene asks for 2 mesh instances (groups expanded), "
                              "over the limit of 1 (raise it with --budget instances=N)\n");
    EXPECT_FALSE(fs::exists(dir / "x.png"));
    run = run_trace(base + "--budget pixels=4e8 --budget instances=2");
    EXPECT_EQ(run.exit_code, 0) << run.output;
    fs::remove_all(dir);
}

TEST(MrtTraceCli, BudgetOptionLeavesTheSceneArgumentAlone) {
    const fs::path dir = temp_dir();
    const TraceRun run = run_trace("--budget instances=5 " + scene_path() + " -o " +
                                   (dir / "x.png").string() + " --width 8 --height 8");
    EXPECT_EQ(run.exit_code, 0) << run.output;
    EXPECT_TRUE(fs::exists(dir / "x.png"));
    fs::remove_all(dir);
}

TEST(MrtTraceCli, BadBudgetAssignmentIsOneLineUsageError) {
    for (const char* assignment : {"bogus=1", "instances", "instances=0", "instances=1.5"}) {
        const TraceRun run =
            run_trace(scene_path() + " -o x.png --budget " + std::string(assignment));
        EXPECT_EQ(run.exit_code, 2) << assignment;
        EXPECT_EQ(count_lines(run.output), 1) << run.output;
        const std::string name(assignment, std::strcspn(assignment, "="));
        EXPECT_NE(run.output.find(name), std::string::npos) << run.output;
    }
}

TEST(MrtTraceCli, ResolutionFromTheCommandLineIsWithinThePixelBudget) {
    const TraceRun run = run_trace(scene_path() + " -o x.png --width 65536 --height 65536");
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.output, "mrt-trace: " + scene_path() +
                              ": the scene asks for 4.29e+09 pixels (--width x --height), over "
                              "the limit of 2.68e+08 (raise it with --budget pixels=N)\n");
}

TEST(MrtTraceCli, GroupsNestedToTheLimitRenderWithEveryMethod) {
    // 40 levels: whitted and distributed used to stop at 32 while cone went on.
    const fs::path dir = temp_dir();
    const fs::path scene = write_file(dir / "chain.json", chain_scene(39));
    for (const char* method : {"whitted", "distributed", "cone", "cone-classic"}) {
        const TraceRun run = run_trace(scene.string() + " -o " + (dir / "x.exr").string() +
                                       " --width 8 --height 8 --method " + method);
        EXPECT_EQ(run.exit_code, 0) << method << ": " << run.output;
    }
    fs::remove_all(dir);
}

TEST(MrtTraceCli, GroupsNestedBeyondTheLimitAreRefusedAlikeByEveryTool) {
    const fs::path dir = temp_dir();
    const fs::path scene = write_file(dir / "chain.json", chain_scene(64));
    const std::string message = scene.string() +
                                ": /groups/g64: the scene asks for 65 levels of group nesting, "
                                "over the limit of 64 (raise it with --budget group-nesting=N)\n";
    for (const char* method : {"whitted", "distributed", "cone", "cone-classic"}) {
        const TraceRun run = run_trace(scene.string() + " -o " + (dir / "x.exr").string() +
                                       " --width 8 --height 8 --method " + method);
        EXPECT_EQ(run.exit_code, 1) << method;
        EXPECT_EQ(run.output, "mrt-trace: " + message) << method;
    }
    const TraceRun preprocess =
        run_tool(MRT_PREPROCESS_EXE, scene.string() + " -o " + (dir / "x.mrh").string());
    EXPECT_EQ(preprocess.exit_code, 1);
    EXPECT_EQ(preprocess.output, "mrt-preprocess: " + message);
    EXPECT_FALSE(fs::exists(dir / "x.mrh"));
    fs::remove_all(dir);
}

TEST(MrtTraceCli, GroupsNestedAsDeepAsAnyToolSupportsDoNotOverflowTheStack) {
    // The raised budget's ceiling: every recursion over groups stays within its stack.
    const fs::path dir = temp_dir();
    const fs::path scene = write_file(dir / "chain.json", chain_scene(255));
    const std::string budget = " --budget group-nesting=1000000";
    for (const char* method : {"whitted", "distributed", "cone"}) {
        const TraceRun run = run_trace(scene.string() + " -o " + (dir / "x.exr").string() +
                                       " --width 8 --height 8 --method " + method + budget);
        EXPECT_EQ(run.exit_code, 0) << method << ": " << run.output;
    }
    const TraceRun preprocess =
        run_tool(MRT_PREPROCESS_EXE, scene.string() + " -o " + (dir / "x.mrh").string() + budget);
    EXPECT_EQ(preprocess.exit_code, 0) << preprocess.output;
    const TraceRun from_hierarchy =
        run_trace((dir / "x.mrh").string() + " -o " + (dir / "y.exr").string() +
                  " --width 8 --height 8 --method cone" + budget);
    EXPECT_EQ(from_hierarchy.exit_code, 0) << from_hierarchy.output;
    // One level more is refused whatever the budget.
    write_file(scene, chain_scene(256));
    const TraceRun deeper = run_trace(scene.string() + " -o " + (dir / "x.exr").string() + budget);
    EXPECT_EQ(deeper.exit_code, 1);
    EXPECT_EQ(deeper.output, "mrt-trace: " + scene.string() +
                                 ": /groups/g256: the scene asks for 257 levels of group nesting, "
                                 "over the 256 levels every tool supports (whatever --budget "
                                 "group-nesting says)\n");
    fs::remove_all(dir);
}

TEST(MrtTraceCli, HierarchyFilesAreHeldToTheSameGroupNestingBudget) {
    const fs::path dir = temp_dir();
    const fs::path scene = write_file(dir / "chain.json", chain_scene(5));
    const fs::path hierarchy = dir / "chain.mrh";
    ASSERT_EQ(run_tool(MRT_PREPROCESS_EXE, scene.string() + " -o " + hierarchy.string()).exit_code,
              0);
    const TraceRun run = run_trace(hierarchy.string() + " -o " + (dir / "x.exr").string() +
                                   " --method cone --budget group-nesting=3");
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(count_lines(run.output), 1) << run.output;
    EXPECT_EQ(run.output.rfind("mrt-trace: " + hierarchy.string() + ": object ", 0), 0u)
        << run.output;
    EXPECT_NE(run.output.find(": the scene asks for 6 levels of group nesting, over the limit of "
                              "3 (raise it with --budget group-nesting=N)\n"),
              std::string::npos)
        << run.output;
    fs::remove_all(dir);
}

TEST(MrtPreprocessCli, RefusesDeepJsonAndGroupChainsInOneLine) {
    const fs::path dir = temp_dir();
    // 100 000 nested arrays followed by more keys of the same object: a stack overflow before.
    const std::string prefix = R"({"ambient": )";
    const fs::path deep =
        write_file(dir / "deep.json", prefix + std::string(100'000, '[') +
                                          std::string(100'000, ']') + R"(, "objects": []})");
    TraceRun run = run_tool(MRT_PREPROCESS_EXE, deep.string() + " -o " + (dir / "x.mrh").string());
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.output, "mrt-preprocess: " + deep.string() +
                              ": line 1, column 76 (byte 75): arrays and objects nest deeper than "
                              "64 levels (a scene needs about 10)\n");
    // 20 000 groups each instancing the next.
    const fs::path chain = write_file(dir / "chain.json", chain_scene(20'000));
    run = run_tool(MRT_PREPROCESS_EXE, chain.string() + " -o " + (dir / "x.mrh").string());
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.output, "mrt-preprocess: " + chain.string() +
                              ": /groups/g64: the scene asks for 20001 levels of group nesting, "
                              "over the limit of 64 (raise it with --budget group-nesting=N)\n");
    EXPECT_FALSE(fs::exists(dir / "x.mrh"));
    // Its budget option: both assignments apply, the scene argument stays the scene.
    const fs::path quads =
        write_file(dir / "quads.json", small_scene("[" + std::string(kQuad) + ", " + kQuad + "]"));
    run = run_tool(MRT_PREPROCESS_EXE, "--budget instances=1 --budget instanced-triangles=100 " +
                                           quads.string() + " -o " + (dir / "x.mrh").string());
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.output, "mrt-preprocess: " + quads.string() +
                              ": /objects: the scene asks for 2 mesh instances (groups expanded), "
                              "over the limit of 1 (raise it with --budget instances=N)\n");
    run = run_tool(MRT_PREPROCESS_EXE, "--budget instances=2 --budget instanced-triangles=3 " +
                                           quads.string() + " -o " + (dir / "x.mrh").string());
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_NE(run.output.find("4 triangles (instances expanded), over the limit of 3"),
              std::string::npos)
        << run.output;
    run = run_tool(MRT_PREPROCESS_EXE, quads.string() + " -o x.mrh --budget nonsense=3");
    EXPECT_EQ(run.exit_code, 2);
    EXPECT_EQ(count_lines(run.output), 1) << run.output;
    fs::remove_all(dir);
}

TEST(MrtCompareCli, HandsItsBudgetAssignmentsToEveryRun) {
    const fs::path dir = temp_dir();
    const fs::path quads =
        write_file(dir / "quads.json", small_scene("[" + std::string(kQuad) + ", " + kQuad + "]"));
    const std::string base = quads.string() + " --out " + (dir / "out").string() +
                             " --method whitted --reference-spp 1 --width 8 --height 8 ";
    TraceRun run = run_tool(MRT_COMPARE_EXE, base + "--budget pixels=1000 --budget instances=1");
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(count_lines(run.output), 1) << run.output;
    EXPECT_NE(run.output.find("2 mesh instances (groups expanded), over the limit of 1"),
              std::string::npos)
        << run.output;
    run = run_tool(MRT_COMPARE_EXE, base + "--budget pixels=1000 --budget instances=2");
    EXPECT_EQ(run.exit_code, 0) << run.output;
    run = run_tool(MRT_COMPARE_EXE, base + "--budget instances=x");
    EXPECT_EQ(run.exit_code, 2);
    EXPECT_EQ(count_lines(run.output), 1) << run.output;
    fs::remove_all(dir);
}

}  // namespace

// ---- Every tool's output paths, checked before any work -------------------------------------

namespace {

std::vector<std::string> entries(const fs::path& dir) {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir)) {
        names.push_back(entry.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
}

TEST(OutputPaths, MrtTraceRefusesAnUnwritableStatsPathBeforeReadingTheScene) {
    const fs::path dir = temp_dir();
    fs::create_directories(dir / "taken.json");
    // The scene does not exist: a refusal that names the stats file was made before reading it.
    const std::string scene = (dir / "missing-scene.json").string();
    const std::string image = (dir / "out.png").string();
    const std::pair<std::string, std::string> cases[] = {
        {(dir / "no-dir" / "stats.json").string(), "cannot write the stats file: directory '" +
                                                       (dir / "no-dir").string() +
                                                       "' does not exist"},
        {(dir / "taken.json").string(), "cannot write the stats file: is a directory"},
    };
    for (const auto& [stats, reason] : cases) {
        const TraceRun run = run_tool(MRT_TRACE_EXE, scene + " -o " + image + " --stats " + stats);
        EXPECT_EQ(run.exit_code, 1);
        EXPECT_EQ(run.output, "mrt-trace: " + stats + ": " + reason + "\n");
    }
    // With a real scene, nothing is rendered or written either.
    const TraceRun run = run_tool(MRT_TRACE_EXE, scene_path() + " -o " + image + " --stats " +
                                                     (dir / "no-dir" / "stats.json").string());
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(count_lines(run.output), 1) << run.output;
    EXPECT_EQ(entries(dir), std::vector<std::string>{"taken.json"});
    fs::remove_all(dir);
}

TEST(OutputPaths, MrtTraceRefusesAnImagePathThatIsADirectory) {
    const fs::path dir = temp_dir();
    fs::create_directories(dir / "out.png");
    const TraceRun run = run_tool(
        MRT_TRACE_EXE, (dir / "missing-scene.json").string() + " -o " + (dir / "out.png").string());
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.output, "mrt-trace: " + (dir / "out.png").string() +
                              ": cannot write image: is a directory\n");
    fs::remove_all(dir);
}

TEST(OutputPaths, MrtPreprocessRefusesAnUnwritableOutputBeforeReadingTheScene) {
    const fs::path dir = temp_dir();
    fs::create_directories(dir / "taken.mrh");
    const std::string scene = (dir / "missing-scene.json").string();
    const std::pair<std::string, std::string> cases[] = {
        {(dir / "no-dir" / "out.mrh").string(), "cannot write the hierarchy file: directory '" +
                                                    (dir / "no-dir").string() + "' does not exist"},
        {(dir / "taken.mrh").string(), "cannot write the hierarchy file: is a directory"},
    };
    for (const auto& [output, reason] : cases) {
        const TraceRun run = run_tool(MRT_PREPROCESS_EXE, scene + " -o " + output);
        EXPECT_EQ(run.exit_code, 1);
        EXPECT_EQ(run.output, "mrt-preprocess: " + output + ": " + reason + "\n");
    }
    EXPECT_EQ(entries(dir), std::vector<std::string>{"taken.mrh"});
    fs::remove_all(dir);
}

TEST(OutputPaths, MrtCompareRefusesAnOutputDirectoryThatIsAFileBeforeRendering) {
    const fs::path dir = temp_dir();
    std::ofstream(dir / "results") << "a file";
    const TraceRun run =
        run_tool(MRT_COMPARE_EXE, scene_path() + " --out " + (dir / "results").string() +
                                      " --width 8 --height 8 --method whitted");
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.output, "mrt-compare: " + (dir / "results").string() +
                              ": cannot create the output directory\n");
    EXPECT_EQ(entries(dir), std::vector<std::string>{"results"});
    fs::remove_all(dir);
}

// ---- Signals: no mip-map directory left behind -----------------------------------------------

/// Spawns mrt-trace with TMPDIR set and the cleanup signals at their default disposition (a
/// test runner may start us with SIGINT ignored, which the child would inherit).
pid_t spawn_trace(const std::vector<std::string>& arguments, const fs::path& tmpdir) {
    std::vector<std::string> strings = {MRT_TRACE_EXE};
    strings.insert(strings.end(), arguments.begin(), arguments.end());
    std::vector<char*> argv;
    for (std::string& s : strings) {
        argv.push_back(s.data());
    }
    argv.push_back(nullptr);
    std::vector<std::string> environment = {"TMPDIR=" + tmpdir.string()};
    for (char** e = environ; *e != nullptr; ++e) {
        if (std::string_view(*e).rfind("TMPDIR=", 0) != 0) {
            environment.emplace_back(*e);
        }
    }
    std::vector<char*> envp;
    for (std::string& s : environment) {
        envp.push_back(s.data());
    }
    envp.push_back(nullptr);
    posix_spawnattr_t attributes;
    posix_spawnattr_init(&attributes);
    sigset_t defaults;
    sigemptyset(&defaults);
    for (const int signal_number : {SIGINT, SIGTERM, SIGHUP}) {
        sigaddset(&defaults, signal_number);
    }
    posix_spawnattr_setsigdefault(&attributes, &defaults);
    sigset_t none;
    sigemptyset(&none);
    posix_spawnattr_setsigmask(&attributes, &none);
    posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETSIGMASK);
    pid_t pid = -1;
    const int error = posix_spawn(&pid, argv[0], nullptr, &attributes, argv.data(), envp.data());
    posix_spawnattr_destroy(&attributes);
    return error == 0 ? pid : -1;
}

TEST(MrtTraceSignals, SigtermSigintAndSighupMidRenderLeaveNoMipMapsAndEndTheRunBySignal) {
    const fs::path dir = temp_dir();
    const std::string textured =
        std::string(MRT_SOURCE_DIR) + "/tests/data/scene/all_features.json";
    for (const int signal_number : {SIGTERM, SIGINT, SIGHUP}) {
        const fs::path tmp = dir / fmt::format("tmp-{}", signal_number);
        fs::create_directories(tmp);
        // Far more work than the test waits for: the signal always arrives mid-render.
        const pid_t pid = spawn_trace({textured, "-o", (dir / "out.exr").string(), "--method",
                                       "distributed", "--spp", "4096", "--threads", "1", "-q"},
                                      tmp);
        ASSERT_GT(pid, 0);
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
        while (fs::is_empty(tmp) && std::chrono::steady_clock::now() < deadline) {
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        EXPECT_FALSE(fs::is_empty(tmp)) << "no mip-map directory appeared";
        std::this_thread::sleep_for(std::chrono::milliseconds(300));
        ::kill(pid, signal_number);
        int status = 0;
        ASSERT_EQ(::waitpid(pid, &status, 0), pid);
        ASSERT_TRUE(WIFSIGNALED(status)) << "exit status " << status;
        EXPECT_EQ(WTERMSIG(status), signal_number);
        EXPECT_TRUE(fs::is_empty(tmp)) << tmp;
        EXPECT_FALSE(fs::exists(dir / "out.exr"));
    }
    fs::remove_all(dir);
}

// ---- Messages --------------------------------------------------------------------------------

TEST(Messages, ATruncatedPngTextureIsOneLineWithoutTheLibrarysOwn) {
    const fs::path dir = temp_dir();
    mrt::Image image(64, 64, mrt::Rgb(0.5f, 0.25f, 0.125f));
    for (int i = 0; i < 64; ++i) {
        image.set(i, (i * 7) % 64, mrt::Rgb(1.0f, 1.0f, 1.0f));
    }
    mrt::write_image(dir / "whole.png", image);
    const auto size = static_cast<std::streamsize>(fs::file_size(dir / "whole.png"));
    std::string bytes(static_cast<std::size_t>(size), '\0');
    std::ifstream(dir / "whole.png", std::ios::binary).read(bytes.data(), size);
    // Cut in the header (libpng fails reading IHDR) and in the pixel data (it fails in IDAT).
    for (const std::size_t length : {std::size_t{20}, bytes.size() / 2}) {
        std::ofstream(dir / "cut.png", std::ios::binary | std::ios::trunc)
            .write(bytes.data(), static_cast<std::streamsize>(length));
        std::ofstream(dir / "scene.json") << R"({
          "camera": {"eye": [0, 1, 3], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 40,
                     "resolution": [8, 8]},
          "materials": {"tex": {"diffuse": 1, "texture": {"file": "cut.png"}}},
          "lights": [{"type": "point", "position": [0, 3, 0], "intensity": 5}],
          "objects": [{"shape": "quad", "size": [2, 2], "material": "tex"}]
        })";
        const TraceRun run =
            run_trace((dir / "scene.json").string() + " -o " + (dir / "out.png").string());
        EXPECT_EQ(run.exit_code, 1);
        EXPECT_EQ(count_lines(run.output), 1) << run.output;
        EXPECT_EQ(run.output.rfind(
                      "mrt-trace: " + (dir / "cut.png").string() + ": cannot read texture: ", 0),
                  0u)
            << run.output;
    }
    fs::remove_all(dir);
}

std::string ellipse_scene(const std::string& u, const std::string& v) {
    return R"({"camera": {"eye": [0, 1, 3], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 40,
                          "resolution": [8, 8]},
              "materials": {"white": {"diffuse": 1}},
              "lights": [{"type": "ellipse", "center": [0, 2, 0], "semi_axis_u": )" +
           u + R"(, "semi_axis_v": )" + v + R"(, "power": 10}],
              "objects": [{"shape": "quad", "size": [2, 2], "material": "white"}]})";
}

/// The loader's message for the scene, or "" when it is accepted.
std::string ellipse_message(const std::string& u, const std::string& v) {
    try {
        mrt::parse_scene(ellipse_scene(u, v), "scene.json");
    } catch (const mrt::Error& e) {
        return e.what();
    }
    return "";
}

TEST(Messages, EllipseAxesAreParallelByTheirAngleAndDegenerateByTheirLength) {
    // Perpendicular axes of 1e-10 are a fine (if tiny) light; so are axes 1e-3 rad apart.
    EXPECT_EQ(ellipse_message("[1e-10, 0, 0]", "[0, 0, 1e-10]"), "");
    EXPECT_EQ(ellipse_message("[1, 0, 0]", "[1, 0, 0.001]"), "");
    EXPECT_EQ(ellipse_message("[1e-20, 0, 0]", "[0, 0, 1e-20]"),
              "scene.json: /lights/0/semi_axis_u: found [1e-20,0,0], expected an axis at least "
              "1.08e-19 long (its squared length underflows single precision)");
    EXPECT_EQ(ellipse_message("[1, 0, 0]", "[0, 0, 1e-25]"),
              "scene.json: /lights/0/semi_axis_v: found [0,0,1e-25], expected an axis at least "
              "1.08e-19 long (its squared length underflows single precision)");
    EXPECT_EQ(ellipse_message("[1e-5, 0, 0]", "[-2e-5, 1e-12, 0]"),
              "scene.json: /lights/0/semi_axis_v: found [-2e-05,1e-12,0], expected a vector not "
              "parallel to semi_axis_u (non-zero area)");
    EXPECT_EQ(ellipse_message("[1e30, 0, 0]", "[0, 1e30, 0]"),
              "scene.json: /lights/0/semi_axis_v: found [0,1e+30,0], expected axes whose area "
              "π |u| |v| sin θ (here 3.14e+60) single precision can compute");
}

// ---- A hierarchy file that lost a channel its scene needs --------------------------------------

TEST(HierarchyChannels, AFileResealedWithoutItsMirrorChannelIsRefusedByEveryMethod) {
    const fs::path dir = temp_dir();
    std::ofstream(dir / "mirror.json") << R"({
      "camera": {"eye": [0, 1, 3], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 40,
                 "resolution": [8, 8]},
      "materials": {"mirror": {"diffuse": 0.1, "reflectivity": 0.9}},
      "lights": [{"type": "point", "position": [0, 3, 0], "intensity": 5}],
      "objects": [{"shape": "sphere", "radius": 1, "segments": 24, "rings": 12,
                   "material": "mirror"}]
    })";
    const fs::path whole = dir / "whole.mrh";
    const TraceRun built = run_tool(
        MRT_PREPROCESS_EXE, (dir / "mirror.json").string() + " -o " + whole.string() + " -q");
    ASSERT_EQ(built.exit_code, 0) << built.output;
    const fs::path resealed = dir / "resealed.mrh";
    {
        const mrt::SectionFile file = mrt::SectionFile::open(whole, mrt::kHierarchyFileVersion);
        ASSERT_TRUE(file.has(mrt::section_tag("PMIR")));
        mrt::SectionFileWriter writer(mrt::kHierarchyFileVersion);
        for (const mrt::SectionInfo& section : file.sections()) {
            if (section.tag != mrt::section_tag("PMIR")) {
                writer.add(section.tag, file.bytes(section.tag), section.element_size);
            }
        }
        writer.write(resealed);
    }
    const std::string expected =
        "mrt-trace: " + resealed.string() +
        ": section 'PMIR': missing: the scene record's materials need the mirror channel "
        "(reflectivity, roughness, normal gradients), which a reflecting or refracting material "
        "needs\n";
    const TraceRun whole_run = run_trace(whole.string() + " -o " + (dir / "whole.png").string());
    EXPECT_EQ(whole_run.exit_code, 0) << whole_run.output;
    for (const char* method : {"whitted", "cone"}) {
        const TraceRun run = run_trace(resealed.string() + " -o " + (dir / "out.png").string() +
                                       " --method " + method);
        EXPECT_EQ(run.exit_code, 1) << method;
        EXPECT_EQ(run.output, expected) << method;
        EXPECT_FALSE(fs::exists(dir / "out.png")) << method;
    }
    fs::remove_all(dir);
}

TEST(Messages, OutOfMemorySaysWhatTheToolWasDoing) {
    CLI::App app{"a tool", "mrt-tool"};
    char name[] = "mrt-tool";
    char* argv[] = {name, nullptr};
    std::ostringstream err;
    std::streambuf* const old = std::cerr.rdbuf(err.rdbuf());
    const int code = mrt::run_tool(app, 1, argv, []() -> int {
        mrt::set_activity("rendering scene.json (65536×65536, whitted)");
        throw std::bad_alloc();
    });
    mrt::set_activity("");
    const int plain = mrt::run_tool(app, 1, argv, []() -> int { throw std::bad_alloc(); });
    std::cerr.rdbuf(old);
    EXPECT_EQ(code, 1);
    EXPECT_EQ(plain, 1);
    EXPECT_EQ(err.str(),
              "mrt-tool: out of memory while rendering scene.json (65536×65536, whitted)\n"
              "mrt-tool: out of memory\n");
}

}  // namespace
