// SPDX-License-Identifier: BSD-3-Clause
// commerge: byte-size constants and human-readable formatting for reports and error messages.
#pragma once

#include <cstdint>
#include <string>

namespace commerge {

constexpr std::int64_t kKiB = 1024;
constexpr std::int64_t kMiB = 1024 * kKiB;
constexpr std::int64_t kGiB = 1024 * kMiB;

/// "512 B", "1.5 KiB", "123.4 MiB", "3.91 GiB"; "n/a" for negative values (unknown).
std::string FormatBytes(std::int64_t bytes);

}  // namespace commerge
