// SPDX-License-Identifier: BSD-3-Clause
#include "platform/memory/peak_rss.hpp"

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

}  // namespace commerge::platform
