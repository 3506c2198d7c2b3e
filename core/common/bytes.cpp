// SPDX-License-Identifier: BSD-3-Clause
#include "core/common/bytes.hpp"

#include <cinttypes>
#include <cstdio>

namespace commerge {

std::string FormatBytes(std::int64_t bytes) {
  if (bytes < 0) return "n/a";
  char buf[64];
  const double b = static_cast<double>(bytes);
  if (bytes < kKiB) {
    std::snprintf(buf, sizeof buf, "%" PRId64 " B", bytes);
  } else if (bytes < kMiB) {
    std::snprintf(buf, sizeof buf, "%.1f KiB", b / static_cast<double>(kKiB));
  } else if (bytes < kGiB) {
    std::snprintf(buf, sizeof buf, "%.1f MiB", b / static_cast<double>(kMiB));
  } else {
    std::snprintf(buf, sizeof buf, "%.2f GiB", b / static_cast<double>(kGiB));
  }
  return buf;
}

}  // namespace commerge
