// SPDX-License-Identifier: BSD-3-Clause
#include "platform/ros/container_util.hpp"

#include <algorithm>

namespace commerge::platform::container {

std::string Printable(Span<const std::uint8_t> bytes) {
  std::string out = "\"";
  for (std::size_t i = 0; i < bytes.size() && i < 64; ++i) {
    out += (bytes[i] >= 0x20 && bytes[i] < 0x7f) ? static_cast<char>(bytes[i]) : '?';
  }
  if (bytes.size() > 64) out += "...";
  return out + "\"";
}

void EnsureSize(std::vector<std::uint8_t>* buffer, std::size_t bytes) {
  if (buffer->size() < bytes) buffer->resize(bytes);
}

Status ReadInto(ByteSource* source, std::uint64_t offset, std::size_t n, std::vector<std::uint8_t>* buffer) {
  EnsureSize(buffer, std::max<std::size_t>(n, 1));
  return source->ReadAt(offset, n, buffer->data());
}

std::string ChunkWhere(const std::string& source, std::uint64_t chunk_offset, const char* compression) {
  return source + ": chunk at offset " + std::to_string(chunk_offset) + " (" + compression + ")";
}

std::string InChunkWhere(const std::string& chunk_where, const std::string& record, std::uint64_t index,
                         std::uint64_t chunk_byte) {
  return chunk_where + ": " + record + " " + std::to_string(index) + " at chunk byte " + std::to_string(chunk_byte);
}

std::string InFileWhere(const std::string& source, const std::string& record, std::uint64_t offset) {
  return source + ": " + record + " at offset " + std::to_string(offset);
}

Status Prefixed(const std::string& where, const Status& status) {
  return Status(status.code(), where + ": " + status.message());
}

Status PastChunkEnd(const std::string& what, std::uint64_t left, std::uint64_t chunk_size) {
  return DataLoss(what + " ends past the end of the chunk (" + std::to_string(left) + " bytes left of " +
                  std::to_string(chunk_size) + ")");
}

Status PastFileEnd(const ByteSource& source, std::uint64_t offset, const std::string& what, std::uint64_t left) {
  return DataLoss(source.name() + ": truncated at offset " + std::to_string(offset) + ": " + what +
                  " ends past the end of the file (" + std::to_string(left) + " bytes left of " +
                  std::to_string(source.size()) + ")");
}

Status AboveLimit(const std::string& what, std::uint64_t bytes, std::uint64_t limit, const char* limits,
                  const char* field) {
  return DataLoss(what + " of " + std::to_string(bytes) + " bytes is above the limit of " + std::to_string(limit) +
                  " bytes (" + limits + "::" + field + ")");
}

}  // namespace commerge::platform::container
