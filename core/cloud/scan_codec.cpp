// SPDX-License-Identifier: BSD-3-Clause
// Scan codec: int16 centimetres, little-endian, header with count and CRC-32 (layout in the header file).
#include "core/cloud/scan_codec.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include "core/common/little_endian.hpp"

namespace commerge {
namespace {

// Slicing-by-4 tables: kCrcTables[0] is the classic byte table; kCrcTables[k][b] is the CRC of byte b followed
// by k zero bytes, so four input bytes are folded per step.
using CrcTables = std::array<std::array<std::uint32_t, 256>, 4>;
constexpr CrcTables MakeCrcTables() {
  CrcTables t{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? (0xEDB88320u ^ (c >> 1)) : (c >> 1);
    t[0][i] = c;
  }
  for (std::size_t k = 1; k < 4; ++k) {
    for (std::uint32_t i = 0; i < 256; ++i) t[k][i] = (t[k - 1][i] >> 8) ^ t[0][t[k - 1][i] & 0xFFu];
  }
  return t;
}
constexpr CrcTables kCrcTables = MakeCrcTables();

// Exclusive bound of |c * 100| for a kept coordinate: it must round into [-32767, 32767].
constexpr double kCentimetreLimit = static_cast<double>(kMaxAbsQuantizedCoordinate_cm) + 0.5;

// c [m] -> cm, rounded half away from zero; false when not finite or out of range. Exact: a float times 100
// needs at most 24 + 7 significant bits, so the double product is exact, and so is cm +- 0.5 for
// |cm| >= 2^-24 (at most 53 significant bits); below that the sum rounds but truncates to 0 either way.
inline bool QuantizeCm(float c, std::int16_t* q) noexcept {
  const double cm = static_cast<double>(c) * 100.0;
  if (!(std::fabs(cm) < kCentimetreLimit)) return false;  // also false for NaN
  // Adding +-0.5, then truncating toward zero, rounds half away from zero.
  *q = static_cast<std::int16_t>(static_cast<std::int32_t>(cm + (cm < 0.0 ? -0.5 : 0.5)));
  return true;
}

inline float DequantizeCm(std::int16_t q) noexcept {
  return static_cast<float>(static_cast<double>(q) / 100.0);  // nearest float to q / 100 (up to double rounding)
}

inline std::int16_t ToInt16(std::uint16_t u) noexcept {
  // Two's complement without implementation-defined conversion.
  return u < 0x8000u ? static_cast<std::int16_t>(u) : static_cast<std::int16_t>(static_cast<std::int32_t>(u) - 65536);
}

enum class PointClass { kKept, kNonFinite, kOutOfRange };

inline PointClass Classify(const PointXYZI& p, std::int16_t q[3]) noexcept {
  if (!IsFinite(p)) return PointClass::kNonFinite;
  if (!QuantizeCm(p.x, &q[0]) || !QuantizeCm(p.y, &q[1]) || !QuantizeCm(p.z, &q[2])) return PointClass::kOutOfRange;
  return PointClass::kKept;
}

std::uint32_t HeaderAndPayloadCrc(Span<const std::uint8_t> encoded) noexcept {
  const std::uint32_t head = Crc32(encoded.subspan(0, 8));
  return Crc32(encoded.subspan(kEncodedScanHeaderBytes, encoded.size() - kEncodedScanHeaderBytes), head);
}

std::string Hex32(std::uint32_t v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08x", static_cast<unsigned>(v));
  return buf;
}

std::string Num(std::size_t v) { return std::to_string(v); }

}  // namespace

std::uint32_t Crc32(Span<const std::uint8_t> bytes, std::uint32_t crc) noexcept {
  std::uint32_t c = ~crc;
  const std::uint8_t* p = bytes.data();
  std::size_t n = bytes.size();
  for (; n >= 4; n -= 4, p += 4) {
    c ^= static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
    c = kCrcTables[3][c & 0xFFu] ^ kCrcTables[2][(c >> 8) & 0xFFu] ^ kCrcTables[1][(c >> 16) & 0xFFu] ^
        kCrcTables[0][c >> 24];
  }
  for (; n > 0; --n, ++p) c = kCrcTables[0][(c ^ *p) & 0xFFu] ^ (c >> 8);
  return ~c;
}

std::size_t CountEncodablePoints(Span<const PointXYZI> points) noexcept {
  std::size_t kept = 0;
  std::int16_t q[3];
  for (const PointXYZI& p : points) kept += Classify(p, q) == PointClass::kKept;
  return kept;
}

Result<ScanEncodeInfo> EncodeScan(Span<const PointXYZI> points, Span<std::uint8_t> out) {
  ScanEncodeInfo info;
  info.num_input = points.size();
  std::int16_t q[3];
  // One pass when the buffer holds every input point (the usual case); else count first, to check the size.
  const bool room_for_all = points.size() <= kMaxEncodedScanPoints && out.size() >= EncodedScanBytes(points.size());
  if (!room_for_all) {
    std::size_t kept = 0;
    for (const PointXYZI& p : points) kept += Classify(p, q) == PointClass::kKept;
    if (kept > kMaxEncodedScanPoints) {
      return InvalidArgument("scan encoding: " + Num(kept) + " points to encode, more than the format's " +
                             Num(kMaxEncodedScanPoints));
    }
    if (out.size() < EncodedScanBytes(kept)) {
      return ResourceExhausted("scan encoding needs " + Num(EncodedScanBytes(kept)) + " bytes (" + Num(kept) +
                               " points) but the output buffer holds " + Num(out.size()) + " bytes");
    }
  }

  std::uint8_t* dst = out.data();
  std::uint8_t* w = dst + kEncodedScanHeaderBytes;
  for (const PointXYZI& p : points) {
    switch (Classify(p, q)) {
      case PointClass::kKept:
        for (int k = 0; k < 3; ++k, w += 2)
          PutU16Le(w, static_cast<std::uint16_t>(q[k]));  // modulo 2^16: two's complement
        ++info.num_encoded;
        break;
      case PointClass::kNonFinite:
        ++info.dropped_nonfinite;
        break;
      case PointClass::kOutOfRange:
        ++info.dropped_out_of_range;
        break;
    }
  }
  const std::size_t need = EncodedScanBytes(info.num_encoded);
  dst[0] = kScanCodecMagic0;
  dst[1] = kScanCodecMagic1;
  dst[2] = kScanCodecVersion;
  dst[3] = 0;  // flags
  PutU32Le(dst + 4, static_cast<std::uint32_t>(info.num_encoded));
  PutU32Le(dst + 8, HeaderAndPayloadCrc(Span<const std::uint8_t>(dst, need)));
  info.bytes_written = need;
  return info;
}

Result<ScanHeader> ParseScanHeader(Span<const std::uint8_t> encoded) {
  if (encoded.size() < kEncodedScanHeaderBytes) {
    return DataLoss("encoded scan truncated: " + Num(encoded.size()) + " bytes, the header alone needs " +
                    Num(kEncodedScanHeaderBytes));
  }
  const std::uint8_t* p = encoded.data();
  if (p[0] != kScanCodecMagic0 || p[1] != kScanCodecMagic1) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "not an encoded scan: magic 0x%02x 0x%02x, expected 0x43 0x53 ('CS')",
                  static_cast<unsigned>(p[0]), static_cast<unsigned>(p[1]));
    return DataLoss(buf);
  }
  ScanHeader h;
  h.version = p[2];
  h.flags = p[3];
  h.num_points = GetU32Le(p + 4);
  h.crc32 = GetU32Le(p + 8);
  if (h.version != kScanCodecVersion) {
    return Unimplemented("encoded scan version " + std::to_string(h.version) + " is not supported (this build reads " +
                         "version " + std::to_string(kScanCodecVersion) + ")");
  }
  if (h.flags != 0) {
    return Unimplemented("encoded scan has unknown flags " + Hex32(h.flags) + " (version 1 defines none)");
  }
  if (static_cast<std::size_t>(h.num_points) > kMaxEncodedScanPoints) {  // only possible with a 32-bit size_t
    return DataLoss("encoded scan header says " + std::to_string(h.num_points) + " points, more than " +
                    Num(kMaxEncodedScanPoints) + " fit in memory on this platform");
  }
  const std::size_t expected = EncodedScanBytes(h.num_points);
  if (encoded.size() != expected) {
    const bool truncated = encoded.size() < expected;
    return DataLoss("encoded scan " + std::string(truncated ? "truncated" : "oversized") + ": the header says " +
                    std::to_string(h.num_points) + " points = " + Num(expected) + " bytes, the buffer holds " +
                    Num(encoded.size()) + " bytes");
  }
  return h;
}

Result<ScanHeader> VerifyEncodedScan(Span<const std::uint8_t> encoded) {
  Result<ScanHeader> header = ParseScanHeader(encoded);
  if (!header.ok()) return header;
  const std::uint32_t computed = HeaderAndPayloadCrc(encoded);
  if (computed != header->crc32) {
    return DataLoss("encoded scan corrupt: CRC-32 " + Hex32(header->crc32) + " stored, " + Hex32(computed) +
                    " computed over " + Num(encoded.size()) + " bytes (" + std::to_string(header->num_points) +
                    " points)");
  }
  return header;
}

Result<std::size_t> DecodeScan(Span<const std::uint8_t> encoded, std::vector<PointXYZI>* points,
                               std::size_t max_points) {
  if (points == nullptr) return InvalidArgument("DecodeScan: output vector is null");
  points->clear();
  Result<ScanHeader> header = VerifyEncodedScan(encoded);
  if (!header.ok()) return header.status();
  const std::size_t n = header->num_points;
  if (n > max_points) {
    return ResourceExhausted("encoded scan has " + Num(n) + " points, more than the limit of " + Num(max_points));
  }
  points->resize(n);
  const std::uint8_t* r = encoded.data() + kEncodedScanHeaderBytes;
  for (std::size_t i = 0; i < n; ++i, r += kEncodedPointBytes) {
    PointXYZI& p = (*points)[i];
    p.x = DequantizeCm(ToInt16(GetU16Le(r)));
    p.y = DequantizeCm(ToInt16(GetU16Le(r + 2)));
    p.z = DequantizeCm(ToInt16(GetU16Le(r + 4)));
    p.intensity = 0.0f;
  }
  return n;
}

}  // namespace commerge
