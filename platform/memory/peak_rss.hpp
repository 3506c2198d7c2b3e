// SPDX-License-Identifier: BSD-3-Clause
// Resident-set-size figures of this process from /proc/self/status (Linux).
#pragma once

#include <cstdint>
#include <string>

#include "core/common/bytes.hpp"  // FormatBytes for callers printing these figures

namespace commerge::platform {

using commerge::FormatBytes;

struct RssFigures {
  std::int64_t current_bytes = -1;  ///< VmRSS, -1 when unavailable
  std::int64_t peak_bytes = -1;     ///< VmHWM (high-water mark), -1 when unavailable
};

/// Parses a /proc/<pid>/status text (VmRSS, VmHWM in kB). Fields that are missing stay -1.
RssFigures ParseProcStatus(const std::string& status_text);

/// RSS of this process now. Note: under qemu-user the figures include the emulator (+~15 MiB).
RssFigures ReadRss();

}  // namespace commerge::platform
