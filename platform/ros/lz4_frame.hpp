// SPDX-License-Identifier: BSD-3-Clause
// LZ4 frame format (liblz4's LZ4F API) decompression into a buffer of a known size, shared by the container
// readers whose chunks are LZ4 frames: ROS 1 bags (roslz4 writes one frame a chunk) and MCAP (frames back to back).
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge::platform {

/// How many LZ4 frames the input holds.
enum class Lz4Frames : std::uint8_t {
  kOne,        ///< exactly one frame and nothing after it (bytes after its end are an error)
  kOneOrMore,  ///< frames back to back up to the end of the input
};

/// Decompresses `in` into exactly `out_size` bytes at `out`. Errors start with "lz4: ": DataLoss for corrupt or
/// truncated frames and for more or fewer bytes than `out_size`; ResourceExhausted when no decompression context
/// can be created. `size_name` names the expected size in them, as the words before the number: "the chunk header
/// says" gives "lz4: decompressed 10 bytes, the chunk header says 12".
Status DecompressLz4Frame(Span<const std::uint8_t> in, std::uint8_t* out, std::size_t out_size, const char* size_name,
                          Lz4Frames frames);

}  // namespace commerge::platform
