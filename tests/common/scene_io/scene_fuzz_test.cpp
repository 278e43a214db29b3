// Scene files as a render farm meets them: the project's own scenes, mutated a few thousand times
// (truncated, bytes flipped, values swapped for another type, numbers replaced by extremes, JSON
// nested absurdly deep, chains of groups, an object duplicated in place), deterministically. Each
// mutant must be refused with one line naming the scene file, or loaded. In-process through
// parse_scene (also compiled into mrt_scene_fuzz_sanitized_tests, where AddressSanitizer and
// UBSan abort on any bad access or undefined operation of the loader), and through the real
// mrt-trace (8×8, the methods in turn) and mrt-preprocess with a time limit per case: exit 1 or
// 2 with one line on stderr naming the file and no output left behind, or exit 0 within the limit
// with an image free of NaN. Counts per kind of mutation are printed for the record.

#include "common/scene/scene.h"
#include "common/scene_io/data_path.h"
#include "common/scene_io/scene_loader.h"
#include "common/system/error.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#ifdef MRT_TRACE_EXE
#include "common/image/image.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>
#endif

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#ifdef MRT_TRACE_EXE
extern char** environ;
#endif

namespace mrt {
namespace {

namespace fs = std::filesystem;
using OrderedJson = nlohmann::ordered_json;
using Clock = std::chrono::steady_clock;

// ------------------------------------------------------------------------------ the seeds

struct Seed {
    std::string name;  ///< The file's stem.
    std::string text;  ///< Its JSON with every "file" made absolute, so a mutant loads anywhere.
    bool heavy;        ///< Meshes of thousands of triangles or plants: fewer, cheaper cases.
};

/// Every "file" value that resolves (beside the scene or through MRT_DATA) becomes its absolute
/// path, so that mutants written elsewhere still find their meshes and textures.
void absolutize_files(OrderedJson& value, const fs::path& directory) {
    std::vector<OrderedJson*> stack{&value};
    while (!stack.empty()) {
        OrderedJson* v = stack.back();
        stack.pop_back();
        if (v->is_object()) {
            for (auto it = v->begin(); it != v->end(); ++it) {
                if (it.key() == "file" && it->is_string()) {
                    if (const auto path = resolve_data_file(it->get<std::string>(), directory)) {
                        *it = path->lexically_normal().string();
                    }
                } else {
                    stack.push_back(&*it);
                }
            }
        } else if (v->is_array()) {
            for (auto& element : *v) {
                stack.push_back(&element);
            }
        }
    }
}

const std::vector<Seed>& seeds() {
    static const std::vector<Seed> all = [] {
        const fs::path source(MRT_SOURCE_DIR);
        std::vector<fs::path> files = {source / "tests/data/scene/all_features.json"};
        for (const auto& entry : fs::directory_iterator(source / "data/scenes")) {
            if (entry.path().extension() == ".json") {
                files.push_back(entry.path());
            }
        }
        std::sort(files.begin() + 1, files.end());
        std::vector<Seed> out;
        for (const fs::path& file : files) {
            std::ifstream in(file);
            OrderedJson json = OrderedJson::parse(in);
            absolutize_files(json, file.parent_path());
            const std::string stem = file.stem().string();
            const bool heavy = stem == "bunny" || stem.starts_with("field") || stem == "desk";
            out.push_back({stem, json.dump(2), heavy});
        }
        return out;
    }();
    return all;
}

// ------------------------------------------------------------------------------ the mutations

enum class Kind {
    Truncation,
    ByteFlip,
    TypeSwap,
    ExtremeNumber,
    DeepNesting,
    GroupChain,
    DuplicatedInstances,
};
constexpr std::array kKinds = {Kind::Truncation,         Kind::ByteFlip,    Kind::TypeSwap,
                               Kind::ExtremeNumber,      Kind::DeepNesting, Kind::GroupChain,
                               Kind::DuplicatedInstances};

const char* kind_name(Kind kind) {
    switch (kind) {
        case Kind::Truncation:
            return "truncation";
        case Kind::ByteFlip:
            return "byte-flip";
        case Kind::TypeSwap:
            return "type-swap";
        case Kind::ExtremeNumber:
            return "extreme-number";
        case Kind::DeepNesting:
            return "deep-nesting";
        case Kind::GroupChain:
            return "group-chain";
        case Kind::DuplicatedInstances:
            return "duplicated-instances";
    }
    return "?";
}

struct Mutant {
    std::string seed;
    Kind kind;
    int index;  ///< Of the mutant among its seed's.
    std::string text;
    std::string label() const { return seed + "/" + kind_name(kind) + "/" + std::to_string(index); }
};

using Rng = std::mt19937_64;

std::size_t pick(Rng& rng, std::size_t n) {
    return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng);
}

/// Pointers to every value of the document, its root excluded.
std::vector<OrderedJson::json_pointer> value_pointers(const OrderedJson& root) {
    std::vector<OrderedJson::json_pointer> out;
    std::vector<std::pair<const OrderedJson*, OrderedJson::json_pointer>> stack;
    stack.emplace_back(&root, OrderedJson::json_pointer());
    while (!stack.empty()) {
        const auto [value, pointer] = stack.back();
        stack.pop_back();
        if (value != &root) {
            out.push_back(pointer);
        }
        if (value->is_object()) {
            for (auto it = value->begin(); it != value->end(); ++it) {
                stack.emplace_back(&*it, pointer / it.key());
            }
        } else if (value->is_array()) {
            for (std::size_t i = 0; i < value->size(); ++i) {
                stack.emplace_back(&(*value)[i], pointer / i);
            }
        }
    }
    return out;
}

std::vector<OrderedJson::json_pointer> number_pointers(const OrderedJson& root) {
    std::vector<OrderedJson::json_pointer> out;
    for (const auto& pointer : value_pointers(root)) {
        if (root.at(pointer).is_number()) {
            out.push_back(pointer);
        }
    }
    return out;
}

/// Values of every other type than `value`'s.
OrderedJson swapped_type(const OrderedJson& value, Rng& rng) {
    const std::array<OrderedJson, 7> choices = {OrderedJson(1.5),
                                                OrderedJson("swapped"),
                                                OrderedJson::array({1, 2, 3}),
                                                OrderedJson::object({{"x", 1}}),
                                                OrderedJson(nullptr),
                                                OrderedJson(true),
                                                OrderedJson::array()};
    for (;;) {
        const OrderedJson& choice = choices[pick(rng, choices.size())];
        if (choice.type() != value.type() || choice.size() != value.size()) {
            return choice;
        }
    }
}

// As written in the JSON text (1e300 overflows single precision, 4294967297 is 2^32 + 1).
constexpr std::array<const char*, 14> kExtremes = {
    "1e38",   "3.4e38", "-3.4e38", "1e-45", "-0",    "4294967297", "1e300",
    "-1e300", "0",      "-1",      "65536", "1e-30", "1e13",       "2147483648"};

/// `depth` nested arrays (or objects {"a": …}) around a 1.
std::string nested(std::size_t depth, bool objects) {
    std::string out;
    out.reserve(depth * 6 + 1);
    for (std::size_t i = 0; i < depth; ++i) {
        out += objects ? "{\"a\":" : "[";
    }
    out += "1";
    out.append(depth, objects ? '}' : ']');
    return out;
}

/// Replaces the value at `pointer` by the raw JSON text `raw` (which need not be valid JSON).
std::string with_raw_value(OrderedJson document, const OrderedJson::json_pointer& pointer,
                           const std::string& raw) {
    document[pointer] = "\x01placeholder\x01";
    std::string text = document.dump(2);
    const std::string quoted = OrderedJson("\x01placeholder\x01").dump();
    return text.replace(text.find(quoted), quoted.size(), raw);
}

std::string mutate(const Seed& seed, Kind kind, Rng& rng) {
    const std::string& text = seed.text;
    OrderedJson document = OrderedJson::parse(text);
    switch (kind) {
        case Kind::Truncation:
            return text.substr(0, pick(rng, text.size()));
        case Kind::ByteFlip: {
            std::string out = text;
            const std::size_t flips = 1 + pick(rng, 3);
            for (std::size_t f = 0; f < flips; ++f) {
                const std::size_t at = pick(rng, out.size());
                if (pick(rng, 2) == 0) {
                    out[at] = static_cast<char>(out[at] ^ static_cast<char>(1u << pick(rng, 8)));
                } else {
                    constexpr std::string_view kBytes = "[]{}\",:0-9e.\\ \x80\xff";
                    out[at] = kBytes[pick(rng, kBytes.size())];
                }
            }
            return out;
        }
        case Kind::TypeSwap: {
            const auto pointers = value_pointers(document);
            const auto& pointer = pointers[pick(rng, pointers.size())];
            document[pointer] = swapped_type(document[pointer], rng);
            return document.dump(2);
        }
        case Kind::ExtremeNumber: {
            const auto pointers = number_pointers(document);
            const auto& pointer = pointers[pick(rng, pointers.size())];
            return with_raw_value(document, pointer, kExtremes[pick(rng, kExtremes.size())]);
        }
        case Kind::DeepNesting: {
            constexpr std::array<std::size_t, 6> kDepths = {62, 63, 64, 1000, 100'000, 1'000'000};
            const std::size_t depth = kDepths[pick(rng, kDepths.size())];
            const bool objects = pick(rng, 2) == 0;
            if (pick(rng, 3) == 0) {  // An unknown key, followed by the rest of the scene.
                OrderedJson with_key = OrderedJson::object();
                with_key["x_unknown"] = nullptr;
                for (auto it = document.begin(); it != document.end(); ++it) {
                    with_key[it.key()] = *it;
                }
                return with_raw_value(with_key, OrderedJson::json_pointer("/x_unknown"),
                                      nested(depth, objects));
            }
            const auto pointers = value_pointers(document);
            return with_raw_value(document, pointers[pick(rng, pointers.size())],
                                  nested(depth, objects));
        }
        case Kind::GroupChain: {
            constexpr std::array<std::size_t, 7> kLengths = {2, 62, 63, 64, 300, 1000, 20'000};
            const std::size_t length = kLengths[pick(rng, kLengths.size())];
            OrderedJson& objects = document["objects"];
            const std::string leaf = objects.empty() ? "{}" : objects[0].dump();
            objects.push_back(OrderedJson{{"instance", "fuzz_chain_1"}});
            // Written as text: ordered_json finds keys by linear search, quadratic over a long
            // chain.
            const OrderedJson existing = document.value("groups", OrderedJson::object());
            std::string groups = existing.dump();
            groups.pop_back();
            for (std::size_t k = 1; k <= length; ++k) {
                groups +=
                    (k > 1 || !existing.empty() ? ",\"" : "\"") +
                    ("fuzz_chain_" + std::to_string(k)) + "\":{\"objects\":[" +
                    (k < length ? "{\"instance\":\"fuzz_chain_" + std::to_string(k + 1) + "\"}"
                                : leaf) +
                    "]}";
            }
            return with_raw_value(document, OrderedJson::json_pointer("/groups"), groups + "}");
        }
        case Kind::DuplicatedInstances: {
            constexpr std::array<std::size_t, 5> kCopies = {2, 4, 16, 64, 1024};
            const std::size_t copies = kCopies[pick(rng, kCopies.size())];
            OrderedJson& objects = document["objects"];
            if (objects.empty()) {
                return document.dump(2);
            }
            const OrderedJson copied = objects[pick(rng, objects.size())];
            for (std::size_t c = 0; c < copies; ++c) {
                objects.push_back(copied);
            }
            return document.dump(2);
        }
    }
    return text;
}

/// The mutants of every seed: `per_seed` of each (fewer for heavy seeds), kinds in turn, all
/// from seeds fixed by the seed's position and `stream`.
std::vector<Mutant> mutants(std::size_t per_seed, std::size_t per_heavy_seed,
                            std::uint64_t stream) {
    std::vector<Mutant> out;
    for (std::size_t s = 0; s < seeds().size(); ++s) {
        const Seed& seed = seeds()[s];
        Rng rng(0x5eed'0000ull + 1000 * stream + s);
        const std::size_t count = seed.heavy ? per_heavy_seed : per_seed;
        for (std::size_t i = 0; i < count; ++i) {
            const Kind kind = kKinds[i % kKinds.size()];
            out.push_back({seed.name, kind, static_cast<int>(i), mutate(seed, kind, rng)});
        }
    }
    return out;
}

/// Counts of one run, printed per kind.
struct Tally {
    std::map<std::string, std::array<int, 2>> by_kind;  ///< [refused, accepted].
    std::map<std::string, double> seconds_by_seed;
    std::map<std::string, double> seconds_by_kind;
    int refused = 0;
    int accepted = 0;
    std::vector<std::string> failures;

    void add(const Mutant& m, bool accepted_case, double seconds) {
        seconds_by_seed[m.seed] += seconds;
        seconds_by_kind[kind_name(m.kind)] += seconds;
        ++by_kind[kind_name(m.kind)][accepted_case ? 1 : 0];
        ++(accepted_case ? accepted : refused);
    }
    void print(const std::string& title) const {
        std::cout << title << ": " << refused + accepted << " cases, " << refused << " refused, "
                  << accepted << " accepted, " << failures.size() << " failed\n";
        for (const auto& [kind, counts] : by_kind) {
            std::cout << "  " << kind << ": " << counts[0] + counts[1] << " cases, " << counts[0]
                      << " refused, " << counts[1] << " accepted, " << seconds_by_kind.at(kind)
                      << " s\n";
        }
        for (const auto& [seed, seconds] : seconds_by_seed) {
            std::cout << "  " << seed << ": " << seconds << " s\n";
        }
        for (const std::string& failure : failures) {
            std::cout << "  FAILED " << failure << '\n';
        }
    }
};

// ------------------------------------------------------------------------------ in process

/// How much slower the build under test is than the one the limits below are set for. The
/// always-sanitized Release executable fits them (~3× as slow as they need); the whole Debug build
/// under AddressSanitizer and UBSan (MRT_SANITIZE, scripts/test --asan) took 56 and 98 s for the
/// two heaviest group-chain mutants on a loaded 2-core machine.
#ifdef MRT_SANITIZED_BUILD
constexpr double kSlowdown = 12.0;
#else
constexpr double kSlowdown = 1.0;
#endif

// A case that takes longer than this in-process counts as a hang.
constexpr double kInProcessSeconds = 10.0 * kSlowdown;

TEST(SceneFuzz, MutantsAreRefusedInOneLineNamingTheFileOrLoadedInProcess) {
    // 2128 cases (fewer of the seeds that take a second to load): most are refused within a
    // millisecond, chains of 20 000 groups in a few tenths.
    const auto generation_start = Clock::now();
    const std::vector<Mutant> cases = mutants(420, 7, 0);
    std::cout << "generated in "
              << std::chrono::duration<double>(Clock::now() - generation_start).count() << " s\n";
    const fs::path file = fs::temp_directory_path() / "mrt-fuzz-scene.json";
    Tally tally;
    for (const Mutant& m : cases) {
        const auto start = Clock::now();
        bool accepted = false;
        std::string failure;
        try {
            const Scene scene = parse_scene(m.text, file);
            // Expanding the groups is where unbounded recursion used to live.
            (void)scene.instanced_triangle_count();
            accepted = true;
        } catch (const Error& e) {
            const std::string message = e.what();
            if (message.find('\n') != std::string::npos) {
                failure = "message of several lines: " + message;
            } else if (!message.starts_with(file.string() + ": ")) {
                failure = "message not naming the file: " + message;
            }
        } catch (const std::exception& e) {
            failure = std::string("not an mrt::Error: ") + e.what();
        }
        const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
        if (seconds > kInProcessSeconds) {
            failure += " (took " + std::to_string(seconds) + " s)";
        }
        tally.add(m, accepted, seconds);
        if (!failure.empty()) {
            tally.failures.push_back(m.label() + ": " + failure);
        }
    }
    tally.print("parse_scene");
    EXPECT_TRUE(tally.failures.empty());
    EXPECT_GE(tally.refused + tally.accepted, 2000);
    // The mutations must reach both outcomes, or they test little.
    EXPECT_GT(tally.accepted, 100);
    EXPECT_GT(tally.refused, 1000);
}

#ifdef MRT_TRACE_EXE
// ------------------------------------------------------------------------------ the tools

/// A case that takes longer than this is killed and counts as a hang.
constexpr double kToolSeconds = 15.0 * kSlowdown;

struct ToolRun {
    int exit_code = -1;  ///< Or 128 + signal; -2 when killed at the time limit.
    std::string err;
    double seconds = 0.0;
};

std::string read_file(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

/// Runs `exe` with `arguments` (posix_spawn, no shell), stderr to a file, killed after
/// kToolSeconds.
ToolRun run_tool(const std::string& exe, const std::vector<std::string>& arguments,
                 const fs::path& err_file) {
    std::vector<std::string> words = {exe};
    words.insert(words.end(), arguments.begin(), arguments.end());
    std::vector<char*> argv;
    for (std::string& w : words) {
        argv.push_back(w.data());
    }
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, err_file.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ToolRun run;
    const auto start = Clock::now();
    pid_t pid = 0;
    const int spawned = ::posix_spawn(&pid, exe.c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (spawned != 0) {
        run.err = "posix_spawn failed";
        return run;
    }
    int status = 0;
    for (;;) {
        const pid_t done = ::waitpid(pid, &status, WNOHANG);
        run.seconds = std::chrono::duration<double>(Clock::now() - start).count();
        if (done == pid) {
            run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
            break;
        }
        if (run.seconds > kToolSeconds) {
            ::kill(pid, SIGKILL);
            ::waitpid(pid, &status, 0);
            run.exit_code = -2;
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    run.err = read_file(err_file);
    return run;
}

/// Whether a tool's outcome is one of the two allowed; otherwise why not.
std::string judge(const ToolRun& run, const fs::path& scene, const fs::path& output, bool image) {
    if (run.exit_code == -2) {
        return "hang (killed after " + std::to_string(kToolSeconds) + " s)";
    }
    if (run.exit_code == 0) {
        if (!fs::exists(output)) {
            return "exit 0 without output";
        }
        if (image) {
            const Image rendered = read_image(output);
            for (const float v : rendered.data()) {
                if (std::isnan(v)) {
                    return "NaN in the image";
                }
            }
        }
        return "";
    }
    const std::string line = run.err.substr(0, run.err.find('\n'));
    if (run.exit_code != 1 && run.exit_code != 2) {
        return "exit " + std::to_string(run.exit_code) + ": " + line;
    }
    if (std::count(run.err.begin(), run.err.end(), '\n') != 1) {
        return "not exactly one line: " + run.err.substr(0, 300);
    }
    if (line.find(scene.string()) == std::string::npos) {
        return "the line does not name the file: " + line;
    }
    for (const char* forbidden : {"internal error", "out of memory"}) {
        if (line.find(forbidden) != std::string::npos) {
            return line;
        }
    }
    if (fs::exists(output)) {
        return "refused but left " + output.filename().string() + ": " + line;
    }
    return "";
}

TEST(SceneFuzz, ToolsRefuseMutantsInOneLineOrRenderThemWithinTheLimit) {
    const fs::path dir =
        fs::temp_directory_path() / ("mrt_scene_fuzz_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const fs::path scene = dir / "mutant.json";
    const fs::path err = dir / "stderr.txt";
    // 72 runs of mrt-trace and about 30 of mrt-preprocess: each costs a process start (a third of a
    // second of loading libraries) and a render or a preprocess.
    const std::vector<Mutant> cases = mutants(12, 3, 1);
    constexpr std::array<const char*, 3> kMethods = {"whitted", "distributed", "cone"};
    Tally trace_tally;
    Tally preprocess_tally;
    for (const Mutant& m : cases) {
        std::ofstream(scene, std::ios::binary | std::ios::trunc) << m.text;
        // Heavy seeds take seconds to preprocess: whitted and distributed only.
        const auto seed = std::find_if(seeds().begin(), seeds().end(),
                                       [&](const Seed& s) { return s.name == m.seed; });
        const bool light = !seed->heavy;
        // Offset by the seed's position, so that over the seeds each kind meets every method.
        const auto turn =
            static_cast<std::size_t>(m.index) + static_cast<std::size_t>(seed - seeds().begin());
        const std::string method = kMethods[turn % (light ? 3 : 2)];
        const fs::path image = dir / "out.exr";
        fs::remove(image);
        const ToolRun trace =
            run_tool(MRT_TRACE_EXE,
                     {scene.string(), "-o", image.string(), "--method", method, "--width", "8",
                      "--height", "8", "--threads", "1", "--quiet"},
                     err);
        const std::string trace_failure = judge(trace, scene, image, true);
        trace_tally.add(m, trace.exit_code == 0, trace.seconds);
        if (!trace_failure.empty()) {
            trace_tally.failures.push_back(m.label() + " (" + method + "): " + trace_failure);
        }
        if (light && turn % 2 == 1) {
            const fs::path hierarchy = dir / "out.mrh";
            fs::remove(hierarchy);
            const ToolRun preprocess = run_tool(
                MRT_PREPROCESS_EXE,
                {scene.string(), "-o", hierarchy.string(), "--threads", "1", "--quiet"}, err);
            const std::string failure = judge(preprocess, scene, hierarchy, false);
            preprocess_tally.add(m, preprocess.exit_code == 0, preprocess.seconds);
            if (!failure.empty()) {
                preprocess_tally.failures.push_back(m.label() + ": " + failure);
            }
        }
    }
    trace_tally.print("mrt-trace");
    preprocess_tally.print("mrt-preprocess");
    std::error_code ignored;
    fs::remove_all(dir, ignored);
    EXPECT_TRUE(trace_tally.failures.empty());
    EXPECT_TRUE(preprocess_tally.failures.empty());
    EXPECT_GT(trace_tally.accepted, 8);
}
#endif

}  // namespace
}  // namespace mrt
