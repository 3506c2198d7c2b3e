// SPDX-License-Identifier: BSD-3-Clause
// LZF decompression: hand-assembled streams for each token kind, and every bounds check.
#include <doctest/doctest.h>

#include <string>
#include <vector>

#include "platform/io/lzf.hpp"

namespace commerge::platform {
namespace lzf_test {

/// Decompresses `in` into exactly `out_size` bytes; the status and, when OK, the text.
Status Decompress(const std::vector<unsigned char>& in, std::size_t out_size, std::string* text) {
  std::vector<unsigned char> out(out_size, 0xee);
  const Status s = LzfDecompress(Span<const unsigned char>(in), Span<unsigned char>(out));
  text->assign(out.begin(), out.end());
  return s;
}

void CheckFails(const std::vector<unsigned char>& in, std::size_t out_size, const std::string& part) {
  std::string text;
  const Status s = Decompress(in, out_size, &text);
  CHECK(s.code() == StatusCode::kDataLoss);
  INFO("message: ", s.message());
  CHECK(s.message().find(part) != std::string::npos);
}

TEST_CASE("lzf: literal runs, short and extended back references, overlapping copies") {
  std::string text;
  // literal "abc" (ctrl 2); a back reference of 7 + 0 + 2 = 9 bytes from distance 3 (ctrl 0xe0, length byte 0,
  // offset byte 2): the copy overlaps what it writes.
  REQUIRE(Decompress({2, 'a', 'b', 'c', 0xe0, 0, 2}, 12, &text).ok());
  CHECK(text == "abcabcabcabc");
  // a short back reference: length field 1 -> 3 bytes, distance 1: "xxxx".
  REQUIRE(Decompress({0, 'x', 0x20, 0}, 4, &text).ok());
  CHECK(text == "xxxx");
  // the longest copy: 7 + 255 + 2 = 264 bytes from 3 input bytes (kLzfMaxExpansion is its ratio).
  REQUIRE(Decompress({0, 'z', 0xe0, 255, 0}, 265, &text).ok());
  CHECK(text == std::string(265, 'z'));
  CHECK(kLzfMaxExpansion == 88);
  // a distance with high bits: ((ctrl & 0x1f) << 8) + o + 1 = 256 + 0 + 1 = 257 behind.
  std::vector<unsigned char> far = {31};
  for (int i = 0; i < 32; ++i) far.push_back(static_cast<unsigned char>('A' + i % 26));
  for (int k = 0; k < 7; ++k) {
    far.push_back(31);
    for (int i = 0; i < 32; ++i) far.push_back(static_cast<unsigned char>('a' + (k * 32 + i) % 26));
  }
  far.insert(far.end(), {1, '!', '?', 0x21, 0});  // 258 bytes written; copy 3 from 257 behind: bytes 1, 2, 3
  REQUIRE(Decompress(far, 261, &text).ok());
  CHECK(text.substr(258) == "BCD");
  REQUIRE(Decompress({}, 0, &text).ok());
}

TEST_CASE("lzf: truncated input, output overflow, references before the start and short output are errors") {
  CheckFails({5, 'a', 'b'}, 6, "LZF data at byte 0: a literal run of 6 bytes, but only 2 input bytes remain");
  CheckFails({0, 'a', 0x20}, 4, "LZF data at byte 2: the input ends inside a back reference");
  CheckFails({0, 'a', 0xe0, 3}, 20, "LZF data at byte 2: the input ends inside a back reference");
  CheckFails({2, 'a', 'b', 'c'}, 2, "a literal run of 3 bytes overflows the announced 2 uncompressed bytes");
  CheckFails({0, 'a', 0x40, 0}, 4, "a back reference of 4 bytes overflows the announced 4 uncompressed bytes");
  CheckFails({0, 'a', 0x20, 1}, 4, "LZF data at byte 2: a back reference 2 bytes behind output byte 1 points before");
  CheckFails({0x3f, 0xff}, 4, "a back reference 8192 bytes behind output byte 0");
  CheckFails({1, 'a', 'b'}, 3, "3 compressed bytes decompress to 2 bytes, not the announced 3");
}

}  // namespace lzf_test
}  // namespace commerge::platform
