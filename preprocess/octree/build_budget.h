#pragma once
// What one hierarchy build may spend (common/system/budgets.h) and what it has spent:
// representative points over all of the scene's octrees, counted as each node chooses them and
// before they are allocated, and octree levels, checked before a node is made. A refusal is one
// line naming the scene file, the mesh or group, what the scene asks for and the limit.

#include "common/system/budgets.h"

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <string>

namespace mrt {

class BuildBudget {
  public:
    /// Limits `budgets` for the scene loaded from `file` (named by refusals).
    BuildBudget(const Budgets& budgets, std::filesystem::path file)
        : m_budgets(budgets), m_file(std::move(file)) {}

    /// Counts `count` more points, chosen by a node of `where` (a mesh or group, for the
    /// message); throws mrt::Error once the total is over Budgets::points. Nodes count in
    /// parallel, so the total named is what had been chosen when the limit was passed.
    void add_points(std::uint64_t count, const std::string& where);

    /// Throws mrt::Error when a node at `level` (levels below its tree's root) would be deeper
    /// than Budgets::octree_depth allows.
    void check_level(int level, const std::string& where) const;

    std::uint64_t points() const { return m_points.load(std::memory_order_relaxed); }
    const std::filesystem::path& file() const { return m_file; }
    const Budgets& budgets() const { return m_budgets; }

  private:
    Budgets m_budgets;
    std::filesystem::path m_file;
    std::atomic<std::uint64_t> m_points{0};
};

}  // namespace mrt
