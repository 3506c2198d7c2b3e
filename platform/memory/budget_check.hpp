// SPDX-License-Identifier: BSD-3-Clause
// Start-up enforcement of the memory budget (core/memory/budget.hpp) against this machine.
#pragma once

#include <string>

#include "core/memory/budget.hpp"
#include "platform/memory/memory_limits.hpp"

namespace commerge::platform {

/// Exit code of an app whose budget does not fit (distinct from usage errors 1/2 and bad_alloc 4).
constexpr int kExitOverBudget = 3;
/// Exit code after std::bad_alloc (a heap cap or the machine ran out).
constexpr int kExitOutOfMemory = 4;

struct StartupBudget {
  MemoryLimits probed;
  BudgetLimit limit;
  BudgetVerdict verdict;
};

/// Compares `table` with min(board, MemAvailable, cgroup) x 0.9, using the probed figures.
StartupBudget CheckStartupBudget(AppKind app, const BoardSpec& board, const BudgetTable& table,
                                 const MemoryLimits& probed);

/// Multi-line table: module, bytes, basis; then total and limit.
std::string FormatBudgetTable(const BudgetTable& table, const StartupBudget& check);

}  // namespace commerge::platform
