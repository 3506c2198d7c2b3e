// SPDX-License-Identifier: BSD-3-Clause
#include "tests/support/png_reader.hpp"

#include <zlib.h>

#include <cstdio>
#include <cstdlib>

namespace commerge::test {

namespace {

std::uint32_t BigEndian32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
}

int PaethPredictor(int a, int b, int c) {
  const int p = a + b - c;
  const int pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return a;
  return pb <= pc ? b : c;
}

DecodedPng Fail(const std::string& why) {
  DecodedPng d;
  d.error = why;
  return d;
}

}  // namespace

std::uint32_t DecodedPng::At(int x, int y) const {
  const std::size_t i = (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)) * 3;
  return (std::uint32_t{rgb[i]} << 16) | (std::uint32_t{rgb[i + 1]} << 8) | rgb[i + 2];
}

DecodedPng DecodePngBytes(const std::vector<std::uint8_t>& file) {
  static const std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  if (file.size() < 8) return Fail("shorter than the PNG signature");
  for (int i = 0; i < 8; ++i) {
    if (file[static_cast<std::size_t>(i)] != kSignature[i]) return Fail("no PNG signature");
  }
  struct Chunk {
    std::string type;
    std::vector<std::uint8_t> data;
  };
  std::vector<Chunk> chunks;
  std::size_t at = 8;
  while (at < file.size()) {
    if (file.size() - at < 12) return Fail("a chunk header is cut off at byte " + std::to_string(at));
    const std::uint32_t length = BigEndian32(&file[at]);
    if (file.size() - at - 12 < length) return Fail("a chunk of " + std::to_string(length) + " bytes is cut off");
    Chunk chunk;
    chunk.type.assign(reinterpret_cast<const char*>(&file[at + 4]), 4);
    chunk.data.assign(file.begin() + static_cast<std::ptrdiff_t>(at + 8),
                      file.begin() + static_cast<std::ptrdiff_t>(at + 8 + length));
    const uLong crc = crc32(crc32(0L, Z_NULL, 0), &file[at + 4], static_cast<uInt>(length + 4));
    if (BigEndian32(&file[at + 8 + length]) != static_cast<std::uint32_t>(crc)) {
      return Fail("chunk " + chunk.type + ": CRC mismatch");
    }
    chunks.push_back(std::move(chunk));
    at += 12 + length;
  }
  if (chunks.size() < 3 || chunks.front().type != "IHDR" || chunks.back().type != "IEND" ||
      !chunks.back().data.empty()) {
    return Fail("not IHDR ... IEND");
  }
  const std::vector<std::uint8_t>& ihdr = chunks.front().data;
  if (ihdr.size() != 13) return Fail("IHDR of " + std::to_string(ihdr.size()) + " bytes");
  DecodedPng out;
  out.width = static_cast<int>(BigEndian32(&ihdr[0]));
  out.height = static_cast<int>(BigEndian32(&ihdr[4]));
  if (ihdr[8] != 8 || ihdr[9] != 2 || ihdr[10] != 0 || ihdr[11] != 0 || ihdr[12] != 0) {
    return Fail("not 8-bit RGB, deflate, adaptive filtering, no interlace");
  }
  if (out.width <= 0 || out.height <= 0 || out.width > 16384 || out.height > 16384) return Fail("bad size");
  std::vector<std::uint8_t> zdata;
  bool idat_done = false;
  for (std::size_t i = 1; i + 1 < chunks.size(); ++i) {
    if (chunks[i].type != "IDAT") {
      idat_done = idat_done || out.idat_chunks > 0;
      continue;
    }
    if (idat_done) return Fail("IDAT chunks are not consecutive");
    ++out.idat_chunks;
    zdata.insert(zdata.end(), chunks[i].data.begin(), chunks[i].data.end());
  }
  if (out.idat_chunks == 0) return Fail("no IDAT");
  const std::size_t stride = static_cast<std::size_t>(out.width) * 3;
  const std::size_t raw_size = static_cast<std::size_t>(out.height) * (stride + 1);
  std::vector<std::uint8_t> raw(raw_size + 16);
  uLongf raw_len = static_cast<uLongf>(raw.size());
  if (uncompress(raw.data(), &raw_len, zdata.data(), static_cast<uLong>(zdata.size())) != Z_OK) {
    return Fail("the image data does not inflate");
  }
  if (raw_len != raw_size) return Fail("the image data inflates to " + std::to_string(raw_len) + " bytes");
  out.rgb.resize(static_cast<std::size_t>(out.height) * stride);
  for (std::size_t y = 0; y < static_cast<std::size_t>(out.height); ++y) {
    const int filter = raw[y * (stride + 1)];
    if (filter > 4) return Fail("row " + std::to_string(y) + ": filter " + std::to_string(filter));
    out.filters_used.insert(filter);
    const std::uint8_t* in = &raw[y * (stride + 1) + 1];
    std::uint8_t* row = &out.rgb[y * stride];
    const std::uint8_t* up = y > 0 ? row - stride : nullptr;
    for (std::size_t i = 0; i < stride; ++i) {
      const int a = i >= 3 ? row[i - 3] : 0;
      const int b = up ? up[i] : 0;
      const int c = up && i >= 3 ? up[i - 3] : 0;
      int pred = 0;
      if (filter == 1) pred = a;
      if (filter == 2) pred = b;
      if (filter == 3) pred = (a + b) >> 1;
      if (filter == 4) pred = PaethPredictor(a, b, c);
      row[i] = static_cast<std::uint8_t>(in[i] + pred);
    }
  }
  out.ok = true;
  return out;
}

DecodedPng DecodePngFile(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) return Fail("cannot open " + path);
  std::vector<std::uint8_t> bytes;
  std::uint8_t buf[65536];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;) bytes.insert(bytes.end(), buf, buf + n);
  std::fclose(f);
  return DecodePngBytes(bytes);
}

}  // namespace commerge::test
