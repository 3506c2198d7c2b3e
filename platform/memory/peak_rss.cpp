// SPDX-License-Identifier: BSD-3-Clause
#include "platform/memory/peak_rss.hpp"

#include <cinttypes>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace commerge::platform {

namespace {
/// Value of a "Key:   123 kB" line in bytes, or -1.
std::int64_t ParseKbField(const std::string& text, const std::string& key) {
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.compare(0, key.size() + 1, key + ":") != 0) continue;
    long long kb = -1;
    if (std::sscanf(line.c_str() + key.size() + 1, " %lld", &kb) != 1 || kb < 0) return -1;
    return static_cast<std::int64_t>(kb) * 1024;
  }
  return -1;
}
}  // namespace

RssFigures ParseProcStatus(const std::string& status_text) {
  RssFigures r;
  r.current_bytes = ParseKbField(status_text, "VmRSS");
  r.peak_bytes = ParseKbField(status_text, "VmHWM");
  return r;
}

RssFigures ReadRss() {
  std::ifstream in("/proc/self/status");
  if (!in) return {};
  std::ostringstream ss;
  ss << in.rdbuf();
  return ParseProcStatus(ss.str());
}

std::string FormatBytes(std::int64_t bytes) {
  if (bytes < 0) return "n/a";
  char buf[64];
  const double b = static_cast<double>(bytes);
  if (bytes < 1024) {
    std::snprintf(buf, sizeof buf, "%" PRId64 " B", bytes);
  } else if (b < 1024.0 * 1024.0) {
    std::snprintf(buf, sizeof buf, "%.1f KiB", b / 1024.0);
  } else if (b < 1024.0 * 1024.0 * 1024.0) {
    std::snprintf(buf, sizeof buf, "%.1f MiB", b / (1024.0 * 1024.0));
  } else {
    std::snprintf(buf, sizeof buf, "%.2f GiB", b / (1024.0 * 1024.0 * 1024.0));
  }
  return buf;
}

}  // namespace commerge::platform
