// SPDX-License-Identifier: BSD-3-Clause
// TSV tables: header, blank lines, CRLF, short and long rows, empty cells.
#include <doctest/doctest.h>

#include "core/common/tsv_table.hpp"

namespace commerge {
namespace {

TEST_CASE("TSV table: header names the cells of every following row") {
  const auto rows = ParseTsvTable("\nname\tn\tnote\r\nbrock\t200\t\n\nkeller\t171\r\nshort\nlong\t1\t2\t3\n");
  REQUIRE(rows.size() == 4);
  CHECK(rows[0].at("name") == "brock");
  CHECK(rows[0].at("n") == "200");
  CHECK(rows[0].at("note").empty());
  CHECK(rows[1].at("n") == "171");
  CHECK(rows[1].count("note") == 0);
  CHECK(rows[2].size() == 1);
  CHECK(rows[3].at("note") == "2");
  CHECK(rows[3].size() == 3);
  CHECK(ParseTsvTable("").empty());
  CHECK(ParseTsvTable("only\theader\n").empty());
}

}  // namespace
}  // namespace commerge
