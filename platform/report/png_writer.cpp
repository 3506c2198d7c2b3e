// SPDX-License-Identifier: BSD-3-Clause
// WritePng: signature, IHDR, filtered and deflated IDAT chunks, IEND; written to a temporary file and renamed.
#include "platform/report/png_writer.hpp"

#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <unistd.h>
#include <vector>

#include "platform/io/file_util.hpp"

namespace commerge::platform {

namespace {

constexpr std::size_t kMaxIdatBytes = std::size_t{1} << 16;
constexpr int kBytesPerPixel = 3;

void PutU32Be(std::vector<std::uint8_t>* out, std::uint32_t v) {
  out->push_back(static_cast<std::uint8_t>(v >> 24));
  out->push_back(static_cast<std::uint8_t>(v >> 16));
  out->push_back(static_cast<std::uint8_t>(v >> 8));
  out->push_back(static_cast<std::uint8_t>(v));
}

/// Appends one chunk: length, type, data, CRC-32 of type and data.
void PutChunk(std::vector<std::uint8_t>* out, const char type[4], const std::uint8_t* data, std::size_t size) {
  PutU32Be(out, static_cast<std::uint32_t>(size));
  const std::size_t type_at = out->size();
  out->insert(out->end(), type, type + 4);
  out->insert(out->end(), data, data + size);
  const uLong crc = crc32(crc32(0L, Z_NULL, 0), out->data() + type_at, static_cast<uInt>(size + 4));
  PutU32Be(out, static_cast<std::uint32_t>(crc));
}

std::uint8_t Paeth(int a, int b, int c) {
  const int p = a + b - c;
  const int pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return static_cast<std::uint8_t>(a);
  if (pb <= pc) return static_cast<std::uint8_t>(b);
  return static_cast<std::uint8_t>(c);
}

/// Filters one row with PNG filter `type` (0..4) into `out` (row bytes, without the type byte).
void FilterRow(int type, const std::uint8_t* row, const std::uint8_t* prev, std::size_t n, std::uint8_t* out) {
  for (std::size_t i = 0; i < n; ++i) {
    const int a = i >= kBytesPerPixel ? row[i - kBytesPerPixel] : 0;
    const int b = prev ? prev[i] : 0;
    const int c = (prev && i >= kBytesPerPixel) ? prev[i - kBytesPerPixel] : 0;
    int predictor = 0;
    switch (type) {
      case 1: predictor = a; break;
      case 2: predictor = b; break;
      case 3: predictor = (a + b) / 2; break;
      case 4: predictor = Paeth(a, b, c); break;
      default: break;
    }
    out[i] = static_cast<std::uint8_t>(row[i] - predictor);
  }
}

/// Every row as (filter type byte, filtered bytes), choosing per row the filter whose residuals, read as
/// signed bytes, have the smallest absolute sum (the usual PNG heuristic).
std::vector<std::uint8_t> FilteredScanlines(const RgbImage& image) {
  const std::size_t n = static_cast<std::size_t>(image.width()) * kBytesPerPixel;
  const std::size_t rows = static_cast<std::size_t>(image.height());
  std::vector<std::uint8_t> out(rows * (n + 1));
  std::vector<std::uint8_t> trial(n);
  const std::uint8_t* pixels = image.rgb().data();
  for (std::size_t y = 0; y < rows; ++y) {
    const std::uint8_t* row = pixels + y * n;
    const std::uint8_t* prev = y > 0 ? row - n : nullptr;
    std::uint8_t* dst = out.data() + y * (n + 1);
    std::uint64_t best_cost = UINT64_MAX;
    for (int type = 0; type <= 4; ++type) {
      FilterRow(type, row, prev, n, trial.data());
      std::uint64_t cost = 0;
      for (const std::uint8_t v : trial) {
        cost += static_cast<std::uint64_t>(std::abs(static_cast<int>(static_cast<std::int8_t>(v))));
      }
      if (cost < best_cost) {
        best_cost = cost;
        dst[0] = static_cast<std::uint8_t>(type);
        std::copy(trial.begin(), trial.end(), dst + 1);
      }
    }
  }
  return out;
}

Result<std::vector<std::uint8_t>> EncodePng(const std::string& path, const RgbImage& image) {
  if (image.width() <= 0 || image.height() <= 0) {
    return InvalidArgument(path + ": cannot write an empty " + std::to_string(image.width()) + " x " +
                           std::to_string(image.height()) + " image as PNG");
  }
  const std::vector<std::uint8_t> raw = FilteredScanlines(image);
  uLongf packed_size = compressBound(static_cast<uLong>(raw.size()));
  std::vector<std::uint8_t> packed(packed_size);
  const int rc = compress2(packed.data(), &packed_size, raw.data(), static_cast<uLong>(raw.size()), 6);
  if (rc != Z_OK) {
    if (rc == Z_MEM_ERROR) return ResourceExhausted(path + ": zlib ran out of memory compressing the image");
    return Status(StatusCode::kInternal, path + ": zlib compress2 failed with code " + std::to_string(rc));
  }
  packed.resize(packed_size);

  std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  png.reserve(png.size() + packed.size() + 64 + 12 * (packed.size() / kMaxIdatBytes + 1));
  std::vector<std::uint8_t> ihdr;
  PutU32Be(&ihdr, static_cast<std::uint32_t>(image.width()));
  PutU32Be(&ihdr, static_cast<std::uint32_t>(image.height()));
  ihdr.insert(ihdr.end(), {8, 2, 0, 0, 0});  // bit depth 8, RGB, deflate, adaptive filtering, no interlace
  PutChunk(&png, "IHDR", ihdr.data(), ihdr.size());
  for (std::size_t at = 0; at < packed.size(); at += kMaxIdatBytes) {
    PutChunk(&png, "IDAT", packed.data() + at, std::min(kMaxIdatBytes, packed.size() - at));
  }
  PutChunk(&png, "IEND", nullptr, 0);
  return png;
}

Status WriteAll(const std::string& tmp, const std::vector<std::uint8_t>& bytes) {
  auto file = OpenForWrite(tmp);
  if (!file.ok()) return file.status();
  std::FILE* f = file->get();
  if (std::fwrite(bytes.data(), 1, bytes.size(), f) != bytes.size()) {
    return IoError(tmp + ": write failed: " + std::strerror(errno));
  }
  if (std::fflush(f) != 0) return IoError(tmp + ": write failed: " + std::strerror(errno));
  // Data on disk before the rename makes it visible (EINVAL: a special file that cannot be synced).
  if (fsync(fileno(f)) != 0 && errno != EINVAL && errno != EROFS) {
    return IoError(tmp + ": sync failed: " + std::strerror(errno));
  }
  return CloseChecked(std::move(*file), tmp);
}

}  // namespace

Status WritePng(const std::string& path, const RgbImage& image) {
  auto png = EncodePng(path, image);
  if (!png.ok()) return png.status();
  const std::string tmp = path + ".tmp";
  Status written = WriteAll(tmp, *png);
  if (written.ok() && std::rename(tmp.c_str(), path.c_str()) != 0) {
    written = IoError(path + ": cannot rename " + tmp + " to it: " + std::strerror(errno));
  }
  if (!written.ok()) std::remove(tmp.c_str());
  return written;
}

}  // namespace commerge::platform
