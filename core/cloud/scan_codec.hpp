// SPDX-License-Identifier: BSD-3-Clause
// commerge: compact encoding of a voxelised keyframe scan (in the keyframe's sensor frame) for the robot's
// scan store and for transmission to the server.
//
// Layout, version 1. Every integer is little-endian, written byte by byte (independent of the host):
//
//   offset  bytes  field
//   0       2      magic 'C' 'S' (0x43 0x53)
//   2       1      version = 1
//   3       1      flags = 0 (reserved; a decoder rejects unknown bits with Unimplemented)
//   4       4      num_points, u32
//   8       4      CRC-32 (IEEE 802.3 / zlib polynomial) over bytes [0, 8) followed by the payload
//   12      6 * n  payload: for each point, in input order, x, y, z as int16 centimetres (two's complement)
//
// So EncodedScanBytes(n) = 12 + 6 n exactly (6 B per point = BudgetRecordSizes::kStoredPointBytes).
// Intensity is not stored: the server registers scans on geometry only (FPFH, GICP) and intensity scales
// differ between sensors, so one more byte per point (+17 %) buys nothing downstream. A later version can add
// it behind a flag bit.
//
// Quantisation: q = round-half-away-from-zero(c * 100) per coordinate c [m], computed exactly in double
// (a float times 100 is exact in double), so |q / 100 - c| <= 0.005 m. A point is kept only when all three
// coordinates are finite and round into [-32767, 32767] cm (|c| < 327.675 m); the others are dropped and
// counted, never clamped. The value -32768 is never written (the range is symmetric). Decoding returns
// the float nearest to q / 100, so a decoded coordinate is within 0.005 m + half a float ulp of the input.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/memory/budget.hpp"

namespace commerge {

constexpr std::uint8_t kScanCodecMagic0 = 0x43;  ///< 'C'
constexpr std::uint8_t kScanCodecMagic1 = 0x53;  ///< 'S'
constexpr std::uint8_t kScanCodecVersion = 1;
constexpr std::size_t kEncodedScanHeaderBytes = 12;  ///< magic, version, flags, count, CRC
constexpr std::size_t kEncodedPointBytes = 6;        ///< int16 cm x 3
constexpr double kScanQuantum_m = 0.01;              ///< one centimetre per integer step
constexpr std::int32_t kMaxAbsQuantizedCoordinate_cm = 32767;
/// Largest point count a header can carry (u32), also bounded so EncodedScanBytes cannot overflow size_t.
constexpr std::size_t kMaxEncodedScanPoints =
    (SIZE_MAX - kEncodedScanHeaderBytes) / kEncodedPointBytes < std::size_t{0xFFFFFFFFu}
        ? (SIZE_MAX - kEncodedScanHeaderBytes) / kEncodedPointBytes
        : std::size_t{0xFFFFFFFFu};

static_assert(static_cast<std::int64_t>(kEncodedPointBytes) == BudgetRecordSizes::kStoredPointBytes,
              "the budget table sizes the scan store with the codec's bytes per point");

/// Exact size in bytes of an encoded scan holding `num_points` points (header included).
/// @note Precondition: num_points <= kMaxEncodedScanPoints.
constexpr std::size_t EncodedScanBytes(std::size_t num_points) noexcept {
  return kEncodedScanHeaderBytes + kEncodedPointBytes * num_points;
}

/// What EncodeScan() did.
struct ScanEncodeInfo {
  std::size_t num_input = 0;             ///< points passed in
  std::size_t num_encoded = 0;           ///< points written (= the header's num_points)
  std::size_t dropped_nonfinite = 0;     ///< points with a NaN or infinite x, y or z
  std::size_t dropped_out_of_range = 0;  ///< finite points with a coordinate that rounds beyond +-327.67 m
  std::size_t bytes_written = 0;         ///< == EncodedScanBytes(num_encoded)
};

/// Fields of a checked header.
struct ScanHeader {
  std::uint8_t version = 0;
  std::uint8_t flags = 0;
  std::uint32_t num_points = 0;
  std::uint32_t crc32 = 0;  ///< as stored
};

/// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320, as zlib's crc32()). Chains like zlib:
/// Crc32(b, Crc32(a)) == Crc32(a followed by b); start with crc = 0. "123456789" gives 0xCBF43926.
std::uint32_t Crc32(Span<const std::uint8_t> bytes, std::uint32_t crc = 0) noexcept;

/// Number of points EncodeScan() would keep (finite and in range), to size its output buffer:
/// EncodedScanBytes(CountEncodablePoints(points)) bytes. EncodedScanBytes(points.size()) always suffices.
std::size_t CountEncodablePoints(Span<const PointXYZI> points) noexcept;

/// Encodes `points` (sensor frame [m], order kept, intensity dropped) into the front of `out`.
/// Non-finite and out-of-range points are skipped and counted in the result. Never allocates on success.
/// Errors (nothing written): invalid argument when more than kMaxEncodedScanPoints points would be
/// kept; resource exhausted when `out` is smaller than the exact size needed (the message gives both sizes).
Result<ScanEncodeInfo> EncodeScan(Span<const PointXYZI> points, Span<std::uint8_t> out);

/// Checks magic, version, flags and that `encoded.size()` == EncodedScanBytes(num_points) (no CRC check).
/// Errors: data loss (too short for a header, bad magic, size differs from the header's count: truncated or
/// oversized), unimplemented (other version, unknown flags).
Result<ScanHeader> ParseScanHeader(Span<const std::uint8_t> encoded);

/// ParseScanHeader() plus the CRC check (data loss on mismatch, with both values).
Result<ScanHeader> VerifyEncodedScan(Span<const std::uint8_t> encoded);

/// Verifies `encoded` (as VerifyEncodedScan) and replaces `*points` with its points (intensity 0), in the
/// encoded order. Allocates only when `points->capacity()` is too small. Returns the number of points.
/// `max_points` bounds what an untrusted buffer may make this allocate (resource exhausted beyond it).
/// On any error `*points` is cleared; a null `points` is an invalid argument.
Result<std::size_t> DecodeScan(Span<const std::uint8_t> encoded, std::vector<PointXYZI>* points,
                               std::size_t max_points = kMaxEncodedScanPoints);

}  // namespace commerge
