// SPDX-License-Identifier: BSD-3-Clause
#include "platform/ros/lz4_frame.hpp"

#include <lz4frame.h>

#include <memory>
#include <string>

namespace commerge::platform {

// The helpers live in their own namespace: in a unity build other files of the library share this translation unit.
namespace lz4frame {
namespace {

struct DctxFree {
  void operator()(LZ4F_dctx* dctx) const noexcept { LZ4F_freeDecompressionContext(dctx); }
};

}  // namespace
}  // namespace lz4frame

Status DecompressLz4Frame(Span<const std::uint8_t> in, std::uint8_t* out, std::size_t out_size, const char* size_name,
                          Lz4Frames frames) {
  LZ4F_dctx* raw = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION))) {
    return ResourceExhausted("lz4: cannot create a decompression context");
  }
  const std::unique_ptr<LZ4F_dctx, lz4frame::DctxFree> dctx(raw);
  const bool one = frames == Lz4Frames::kOne;
  const std::string expected = std::string(size_name) + " " + std::to_string(out_size);
  std::size_t in_pos = 0;
  std::size_t out_pos = 0;
  std::size_t hint = 1;  // 0: the frame has ended
  // One frame: until it ends. Frames back to back: until the input is used up (liblz4 starts the next frame itself).
  while (one ? hint != 0 : in_pos < in.size()) {
    std::size_t out_avail = out_size - out_pos;
    std::size_t in_avail = in.size() - in_pos;
    hint = LZ4F_decompress(dctx.get(), out + out_pos, &out_avail, in.data() + in_pos, &in_avail, nullptr);
    if (LZ4F_isError(hint)) {
      return DataLoss(std::string("lz4: ") + LZ4F_getErrorName(hint) + " after " + std::to_string(in_pos) + " of " +
                      std::to_string(in.size()) + " compressed bytes");
    }
    in_pos += in_avail;
    out_pos += out_avail;
    // No progress inside a frame: with room left in `out` the input ends inside the frame, without it the frame holds
    // more than `out_size` bytes. Frames back to back: input used up inside a frame is a cut frame.
    const bool stalled = hint != 0 && in_avail == 0 && out_avail == 0;
    if (hint != 0 && (one ? stalled && out_pos != out_size : in_pos == in.size())) {
      return DataLoss("lz4: the frame ends early (truncated) after " + std::to_string(out_pos) +
                      " decompressed bytes; " + expected);
    }
    if (stalled) {
      return DataLoss("lz4: decompressed more than the " + std::to_string(out_size) + " bytes " + size_name);
    }
  }
  if (out_pos != out_size) return DataLoss("lz4: decompressed " + std::to_string(out_pos) + " bytes, " + expected);
  // Frames back to back: the loop has used up the input.
  if (in_pos != in.size()) {
    return DataLoss("lz4: " + std::to_string(in.size() - in_pos) + " bytes after the end of the lz4 frame");
  }
  return Status::Ok();
}

}  // namespace commerge::platform
