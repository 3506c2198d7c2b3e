// SPDX-License-Identifier: BSD-3-Clause
// LZF decompression (Marc Lehmann's liblzf format, used by PCL's DATA binary_compressed), written from the format:
//   control byte c < 32:   a literal run: the next c + 1 input bytes are copied to the output;
//   control byte c >= 32:  a back reference: length L = c >> 5 (L = 7: L += the next byte), then one byte o;
//                          L + 2 bytes are copied from distance ((c & 0x1f) << 8) + o + 1 behind the output's end
//                          (the source may overlap what is being written: byte by byte).
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge::platform {

/// The most output bytes one input byte of LZF can become: a 3-byte back reference copies at most
/// 7 + 255 + 2 = 264 bytes, and no other token does better (literal runs shrink, 2-byte references copy at most 8).
/// So a block of C compressed bytes decompresses to at most kLzfMaxExpansion * C bytes.
constexpr std::uint64_t kLzfMaxExpansion = (7 + 255 + 2) / 3;

/// Decompresses all of `in` into `out`, which must be filled exactly (its size is the announced uncompressed
/// size). Every read and write is bounds-checked. Errors (data loss) say what is wrong and at which input byte:
/// input ending inside a token, output that would exceed `out`, a back reference before the output's start,
/// or input that ends before `out` is filled. The message does not name a file: callers prefix it.
Status LzfDecompress(Span<const unsigned char> in, Span<unsigned char> out);

}  // namespace commerge::platform
