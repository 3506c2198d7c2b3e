// SPDX-License-Identifier: BSD-3-Clause
// Helpers shared by the recording readers that walk a file of records and chunks (ros1_bag.cpp, mcap_reader.cpp):
// little-endian u64, quoting bytes from the file, reading into a reused buffer, and the wording of their error
// messages (where a record is, truncation, limits).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/common/little_endian.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "platform/ros/byte_source.hpp"

namespace commerge::platform::container {

inline std::uint64_t GetU64Le(const std::uint8_t* p) noexcept {
  return static_cast<std::uint64_t>(GetU32Le(p)) | (static_cast<std::uint64_t>(GetU32Le(p + 4)) << 32);
}

/// Bytes from the file, quoted for an error message: non-printable bytes as '?', at most 64 of them.
std::string Printable(Span<const std::uint8_t> bytes);

/// Grows `buffer` to at least `bytes` (never shrinks it).
void EnsureSize(std::vector<std::uint8_t>* buffer, std::size_t bytes);

/// Reads `n` bytes at `offset` into the start of `buffer`, grown to at least max(n, 1) bytes first.
Status ReadInto(ByteSource* source, std::uint64_t offset, std::size_t n, std::vector<std::uint8_t>* buffer);

/// "<source>: chunk at offset N (<compression>)".
std::string ChunkWhere(const std::string& source, std::uint64_t chunk_offset, const char* compression);
/// "<chunk_where>: <record> K at chunk byte B": the K-th record of a chunk (0-based), B bytes into its data.
std::string InChunkWhere(const std::string& chunk_where, const std::string& record, std::uint64_t index,
                         std::uint64_t chunk_byte);
/// "<source>: <record> at offset N".
std::string InFileWhere(const std::string& source, const std::string& record, std::uint64_t offset);

/// `status` with "<where>: " before its message.
Status Prefixed(const std::string& where, const Status& status);

/// DataLoss "<what> ends past the end of the chunk (L bytes left of S)"; the caller puts where before it.
Status PastChunkEnd(const std::string& what, std::uint64_t left, std::uint64_t chunk_size);
/// DataLoss "<source>: truncated at offset N: <what> ends past the end of the file (L bytes left of S)".
Status PastFileEnd(const ByteSource& source, std::uint64_t offset, const std::string& what, std::uint64_t left);
/// DataLoss "<what> of N bytes is above the limit of L bytes (<limits>::<field>)"; the caller puts where before it.
Status AboveLimit(const std::string& what, std::uint64_t bytes, std::uint64_t limit, const char* limits,
                  const char* field);

}  // namespace commerge::platform::container
