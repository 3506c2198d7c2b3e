// SPDX-License-Identifier: BSD-3-Clause
// String checks for test assertions (error messages, logs, file contents).
#pragma once

#include <string>

namespace commerge::test {

/// True when `part` occurs in `text`.
inline bool Contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace commerge::test
