// mrt-trace as a user meets it: exit codes, one-line messages naming the file, and the stats
// JSON contract.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>

namespace {

namespace fs = std::filesystem;

struct TraceRun {
    int exit_code;
    std::string output;  ///< stdout and stderr together
};

TraceRun run_trace(const std::string& arguments) {
    const std::string command = std::string(MRT_TRACE_EXE) + " " + arguments + " 2>&1";
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
    for (const char* args :
         {"--max-anisotropy 4", "--no-level-blend", "--node-frames", "--triangle-weight paper"}) {
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

/// Runs any tool with `arguments` (shell words), stdout and stderr together.
TraceRun run_exe(const std::string& exe, const std::string& arguments) {
    const std::string command = exe + " " + arguments + " 2>&1";
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
        run_exe(MRT_PREPROCESS_EXE, scene.string() + " -o " + (dir / "x.mrh").string());
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
        run_exe(MRT_PREPROCESS_EXE, scene.string() + " -o " + (dir / "x.mrh").string() + budget);
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
    ASSERT_EQ(run_exe(MRT_PREPROCESS_EXE, scene.string() + " -o " + hierarchy.string()).exit_code,
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
    TraceRun run = run_exe(MRT_PREPROCESS_EXE, deep.string() + " -o " + (dir / "x.mrh").string());
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.output, "mrt-preprocess: " + deep.string() +
                              ": line 1, column 76 (byte 75): arrays and objects nest deeper than "
                              "64 levels (a scene needs about 10)\n");
    // 20 000 groups each instancing the next.
    const fs::path chain = write_file(dir / "chain.json", chain_scene(20'000));
    run = run_exe(MRT_PREPROCESS_EXE, chain.string() + " -o " + (dir / "x.mrh").string());
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.output, "mrt-preprocess: " + chain.string() +
                              ": /groups/g64: the scene asks for 20001 levels of group nesting, "
                              "over the limit of 64 (raise it with --budget group-nesting=N)\n");
    EXPECT_FALSE(fs::exists(dir / "x.mrh"));
    // Its budget option: both assignments apply, the scene argument stays the scene.
    const fs::path quads =
        write_file(dir / "quads.json", small_scene("[" + std::string(kQuad) + ", " + kQuad + "]"));
    run = run_exe(MRT_PREPROCESS_EXE, "--budget instances=1 --budget instanced-triangles=100 " +
                                          quads.string() + " -o " + (dir / "x.mrh").string());
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.output, "mrt-preprocess: " + quads.string() +
                              ": /objects: the scene asks for 2 mesh instances (groups expanded), "
                              "over the limit of 1 (raise it with --budget instances=N)\n");
    run = run_exe(MRT_PREPROCESS_EXE, "--budget instances=2 --budget instanced-triangles=3 " +
                                          quads.string() + " -o " + (dir / "x.mrh").string());
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_NE(run.output.find("4 triangles (instances expanded), over the limit of 3"),
              std::string::npos)
        << run.output;
    run = run_exe(MRT_PREPROCESS_EXE, quads.string() + " -o x.mrh --budget nonsense=3");
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
    TraceRun run = run_exe(MRT_COMPARE_EXE, base + "--budget pixels=1000 --budget instances=1");
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(count_lines(run.output), 1) << run.output;
    EXPECT_NE(run.output.find("2 mesh instances (groups expanded), over the limit of 1"),
              std::string::npos)
        << run.output;
    run = run_exe(MRT_COMPARE_EXE, base + "--budget pixels=1000 --budget instances=2");
    EXPECT_EQ(run.exit_code, 0) << run.output;
    run = run_exe(MRT_COMPARE_EXE, base + "--budget instances=x");
    EXPECT_EQ(run.exit_code, 2);
    EXPECT_EQ(count_lines(run.output), 1) << run.output;
    fs::remove_all(dir);
}

}  // namespace
