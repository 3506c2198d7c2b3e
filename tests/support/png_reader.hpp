// SPDX-License-Identifier: BSD-3-Clause
// An independent reader of the 8-bit RGB, non-interlaced PNG files the report writer makes (tests only): walks the
// chunks checking every length and CRC-32 (zlib's crc32), requires IHDR first, consecutive IDATs and an empty IEND
// last, inflates with zlib's uncompress and undoes all five row filters. No doctest inside, so the test tools
// (cm_check_exchange_outputs) use it too.
#pragma once

#include <cstdint>
#include <set>
#include <string>
#include <vector>

namespace commerge::test {

struct DecodedPng {
  bool ok = false;
  std::string error;  ///< why it is not a valid file (when !ok)
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  ///< width x height x 3, row-major
  std::set<int> filters_used;
  std::size_t idat_chunks = 0;
  /// The pixel (x, y) as 0xRRGGBB (precondition: inside).
  std::uint32_t At(int x, int y) const;
};

DecodedPng DecodePngFile(const std::string& path);
DecodedPng DecodePngBytes(const std::vector<std::uint8_t>& file);

}  // namespace commerge::test
