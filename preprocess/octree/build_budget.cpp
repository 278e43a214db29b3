#include "preprocess/octree/build_budget.h"

#include <algorithm>

namespace mrt {

void BuildBudget::add_points(std::uint64_t count, const std::string& where) {
    std::uint64_t before = m_points.load(std::memory_order_relaxed);
    while (!m_points.compare_exchange_weak(before, saturating_add(before, count),
                                           std::memory_order_relaxed)) {
    }
    check_budget(m_budgets, "points", saturating_add(before, count),
                 "representative points (counted so far)", m_file, where);
}

void BuildBudget::check_level(int level, const std::string& where) const {
    check_budget(m_budgets, "octree-depth", static_cast<std::uint64_t>(std::max(level, 0)),
                 "octree levels below a root", m_file, where);
}

}  // namespace mrt
