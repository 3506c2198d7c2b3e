// SPDX-License-Identifier: BSD-3-Clause
// commerge: a tab-separated table with a header line (the benchmark indexes in ../shared/data are TSV).
// Pure text in, rows out: the caller reads the file.
#pragma once

#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace commerge {

using TsvRow = std::map<std::string, std::string>;  ///< column name -> cell text

/// Rows in text order. The first non-empty line is the header; blank lines and a trailing '\r' are ignored;
/// a row with fewer cells than the header lacks the missing columns, extra cells are ignored.
std::vector<TsvRow> ParseTsvTable(std::string_view text);

}  // namespace commerge
