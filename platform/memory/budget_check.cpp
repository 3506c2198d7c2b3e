// SPDX-License-Identifier: BSD-3-Clause
#include "platform/memory/budget_check.hpp"

#include <cstdio>

#include "core/common/bytes.hpp"

namespace commerge::platform {

StartupBudget CheckStartupBudget(AppKind app, const BoardSpec& board, const BudgetTable& table,
                                 const MemoryLimits& probed) {
  StartupBudget s;
  s.probed = probed;
  s.limit = EffectiveLimit(board, probed.mem_available_bytes, probed.cgroup_limit_bytes);
  if (!probed.meminfo_warning.empty()) s.limit.source += "; " + probed.meminfo_warning;
  s.verdict = CheckBudget(app, table, s.limit);
  return s;
}

std::string FormatBudgetTable(const BudgetTable& table, const StartupBudget& check) {
  std::string out;
  char line[512];
  std::snprintf(line, sizeof line, "  %-28s %12s  %s\n", "module", "budget", "basis");
  out += line;
  for (const BudgetEntry& e : table.entries()) {
    std::snprintf(line, sizeof line, "  %-28s %12s  %s\n", e.module.c_str(), FormatBytes(e.bytes).c_str(),
                  e.basis.c_str());
    out += line;
  }
  std::snprintf(line, sizeof line, "  %-28s %12s\n", "total", FormatBytes(table.total_bytes()).c_str());
  out += line;
  std::snprintf(line, sizeof line, "  %-28s %12s  %s\n", "limit", FormatBytes(check.limit.bytes).c_str(),
                check.limit.source.c_str());
  out += line;
  std::snprintf(line, sizeof line, "  %-28s %12s  cgroup: %s\n", "MemAvailable",
                FormatBytes(check.probed.mem_available_bytes).c_str(), check.probed.cgroup_source.c_str());
  out += line;
  return out;
}

}  // namespace commerge::platform
