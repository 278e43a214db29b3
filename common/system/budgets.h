#pragma once
// Limits on the work a scene may ask for. A render farm reads scene files it did not write: a
// few bytes of JSON can ask for 2^64 triangles, a 65536-deep chain of groups or an octree of
// 10^30 voxels. Every such count is computed in saturating arithmetic *before* the work is done
// and refused, with what the scene asks for and the limit, when it is over its budget. Users
// with bigger scenes raise a limit with `--budget NAME=VALUE` (mrt-preprocess, mrt-trace,
// mrt-compare). docs/scene-format.md lists the budgets and their defaults.

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <limits>
#include <string>
#include <string_view>

namespace mrt {

/// One limit per kind of work; the defaults are far above every scene the project ships (the
/// field at 100 m has 126 M instanced triangles) and far below what exhausts 24 GB or a day.
struct Budgets {
    /// Triangles after expanding every instance (what whitted's BVH and the cone tracer see).
    std::uint64_t instanced_triangles = 4'000'000'000;
    /// Mesh placements after expanding every group instance (instance records built and walked).
    std::uint64_t instances = 100'000'000;
    /// Triangles one procedural shape (sphere, checkerboard, plant…) generates.
    std::uint64_t procedural_triangles = 20'000'000;
    /// Levels of groups instancing groups, counting the world as level 1.
    std::uint64_t group_nesting = 64;
    /// Levels of the point octree below its root.
    std::uint64_t octree_depth = 48;
    /// Representative points (surfels) a hierarchy may hold, over all its octrees.
    std::uint64_t points = 200'000'000;
    /// Pixels of one image (width × height), rendered or read as a texture.
    std::uint64_t pixels = 1ull << 28;
};

/// The budget names of the command line, in the order `--help` and the docs list them.
inline constexpr std::string_view kBudgetNames[] = {"instanced-triangles",
                                                    "instances",
                                                    "procedural-triangles",
                                                    "group-nesting",
                                                    "octree-depth",
                                                    "points",
                                                    "pixels"};

/// The limit of `name` (one of kBudgetNames); throws mrt::Error naming the valid ones.
std::uint64_t& budget(Budgets& budgets, std::string_view name);
std::uint64_t budget(const Budgets& budgets, std::string_view name);

/// Applies one `NAME=VALUE` assignment of the command line (VALUE an integer, or a number such
/// as 2e9 that is one); throws mrt::Error saying what was expected.
void set_budget(Budgets& budgets, std::string_view assignment);

/// Throws mrt::Error "FILE: LOCATION: the scene asks for ASKED WHAT, over the limit of LIMIT
/// (raise it with --budget NAME=N)" when asked > the limit of `name`. `what` describes the unit
/// ("instanced triangles"), `location` is a JSON pointer or another position (may be empty).
void check_budget(const Budgets& budgets, std::string_view name, std::uint64_t asked,
                  std::string_view what, const std::filesystem::path& file,
                  const std::string& location);

/// a + b and a × b, clamped to the largest uint64 instead of wrapping, so a count that
/// overflows still compares as over any budget.
constexpr std::uint64_t saturating_add(std::uint64_t a, std::uint64_t b) {
    constexpr std::uint64_t kMax = std::numeric_limits<std::uint64_t>::max();
    return a > kMax - b ? kMax : a + b;
}
constexpr std::uint64_t saturating_mul(std::uint64_t a, std::uint64_t b) {
    constexpr std::uint64_t kMax = std::numeric_limits<std::uint64_t>::max();
    return (a != 0 && b > kMax / a) ? kMax : a * b;
}

/// The help text of the `--budget` option: every name with its default.
std::string budget_help();

std::ostream& operator<<(std::ostream& os, const Budgets& b);

}  // namespace mrt
