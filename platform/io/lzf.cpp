// SPDX-License-Identifier: BSD-3-Clause
#include "platform/io/lzf.hpp"

#include <cstring>
#include <string>

namespace commerge::platform {

namespace lzf_impl {

constexpr unsigned kLiteralLimit = 1u << 5;  ///< control bytes below this start a literal run
constexpr unsigned kExtendedLength = 7;      ///< this 3-bit length means "add the next byte"

std::string At(std::size_t input_byte) { return "LZF data at byte " + std::to_string(input_byte) + ": "; }

/// A literal run of `length` bytes at in[*ip]; advances both positions.
Status CopyLiteral(Span<const unsigned char> in, Span<unsigned char> out, std::size_t length, std::size_t* ip,
                   std::size_t* op) {
  if (length > in.size() - *ip) {
    return DataLoss(At(*ip - 1) + "a literal run of " + std::to_string(length) + " bytes, but only " +
                    std::to_string(in.size() - *ip) + " input bytes remain (truncated)");
  }
  if (length > out.size() - *op) {
    return DataLoss(At(*ip - 1) + "a literal run of " + std::to_string(length) + " bytes overflows the announced " +
                    std::to_string(out.size()) + " uncompressed bytes");
  }
  std::memcpy(out.data() + *op, in.data() + *ip, length);
  *ip += length;
  *op += length;
  return Status::Ok();
}

/// A back reference whose control byte `ctrl` was at in[*ip - 1]; advances both positions.
Status CopyBackReference(Span<const unsigned char> in, Span<unsigned char> out, unsigned ctrl, std::size_t* ip,
                         std::size_t* op) {
  const std::size_t start = *ip - 1;
  std::size_t length = ctrl >> 5;
  const std::size_t needed = length == kExtendedLength ? 2 : 1;
  if (needed > in.size() - *ip) return DataLoss(At(start) + "the input ends inside a back reference (truncated)");
  if (length == kExtendedLength) length += in[(*ip)++];
  length += 2;
  const std::size_t distance = ((std::size_t{ctrl} & 0x1f) << 8) + in[(*ip)++] + 1;
  if (distance > *op) {
    return DataLoss(At(start) + "a back reference " + std::to_string(distance) + " bytes behind output byte " +
                    std::to_string(*op) + " points before the start of the data (corrupt)");
  }
  if (length > out.size() - *op) {
    return DataLoss(At(start) + "a back reference of " + std::to_string(length) + " bytes overflows the announced " +
                    std::to_string(out.size()) + " uncompressed bytes");
  }
  unsigned char* dst = out.data() + *op;
  const unsigned char* src = dst - distance;
  for (std::size_t i = 0; i < length; ++i) dst[i] = src[i];  // overlapping copies repeat the pattern
  *op += length;
  return Status::Ok();
}

}  // namespace lzf_impl

Status LzfDecompress(Span<const unsigned char> in, Span<unsigned char> out) {
  std::size_t ip = 0, op = 0;
  while (ip < in.size()) {
    const unsigned ctrl = in[ip++];
    const Status s = ctrl < lzf_impl::kLiteralLimit ? lzf_impl::CopyLiteral(in, out, ctrl + 1, &ip, &op)
                                                     : lzf_impl::CopyBackReference(in, out, ctrl, &ip, &op);
    if (!s.ok()) return s;
  }
  if (op != out.size()) {
    return DataLoss("LZF data: " + std::to_string(in.size()) + " compressed bytes decompress to " + std::to_string(op) +
                    " bytes, not the announced " + std::to_string(out.size()) + " (truncated)");
  }
  return Status::Ok();
}

}  // namespace commerge::platform
