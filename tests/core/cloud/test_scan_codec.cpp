// SPDX-License-Identifier: BSD-3-Clause
// Scan codec against an independent reference: a bit-by-bit CRC-32, a byte layout written from the format
// description, and exact quantisation bounds computed in double.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/cloud/scan_codec.hpp"
#include "tests/support/scan_chunks.hpp"
#include "tests/support/strings.hpp"

namespace commerge {
namespace {

using test::Contains;
using test::EncodeForTest;

// Bitwise CRC-32 (no table), straight from the polynomial.
std::uint32_t ReferenceCrc32(const std::vector<std::uint8_t>& bytes) {
  std::uint32_t c = 0xFFFFFFFFu;
  for (std::uint8_t b : bytes) {
    c ^= b;
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
  }
  return ~c;
}

// Round half away from zero of v * 100, in long double.
long ReferenceCm(float v) { return std::lround(static_cast<long double>(v) * 100.0L); }

bool ReferenceKeeps(const PointXYZI& p) {
  for (float c : {p.x, p.y, p.z}) {
    if (!std::isfinite(c) || std::labs(ReferenceCm(c)) > 32767) return false;
  }
  return true;
}

// The encoding written from the layout table in scan_codec.hpp.
std::vector<std::uint8_t> ReferenceEncode(const std::vector<PointXYZI>& points) {
  std::vector<std::uint8_t> payload;
  std::uint32_t n = 0;
  for (const PointXYZI& p : points) {
    if (!ReferenceKeeps(p)) continue;
    ++n;
    for (float c : {p.x, p.y, p.z}) {
      const long q = ReferenceCm(c);
      const auto u = static_cast<std::uint16_t>(q < 0 ? q + 65536 : q);
      payload.push_back(static_cast<std::uint8_t>(u % 256));
      payload.push_back(static_cast<std::uint8_t>(u / 256));
    }
  }
  std::vector<std::uint8_t> crc_input = {'C',
                                         'S',
                                         1,
                                         0,
                                         static_cast<std::uint8_t>(n % 256),
                                         static_cast<std::uint8_t>((n >> 8) % 256),
                                         static_cast<std::uint8_t>((n >> 16) % 256),
                                         static_cast<std::uint8_t>(n >> 24)};
  crc_input.insert(crc_input.end(), payload.begin(), payload.end());
  const std::uint32_t crc = ReferenceCrc32(crc_input);
  std::vector<std::uint8_t> out(crc_input.begin(), crc_input.begin() + 8);
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::uint8_t>((crc >> (8 * i)) & 0xFFu));
  out.insert(out.end(), payload.begin(), payload.end());
  return out;
}

std::vector<PointXYZI> RandomCloud(std::mt19937& rng, std::size_t n, float extent_m) {
  std::uniform_real_distribution<float> u(-extent_m, extent_m);
  std::vector<PointXYZI> cloud(n);
  for (PointXYZI& p : cloud) p = {u(rng), u(rng), u(rng), u(rng)};
  return cloud;
}

std::int16_t StoredCm(const std::vector<std::uint8_t>& buf, std::size_t point, int axis) {
  const std::size_t at = 12 + 6 * point + 2 * static_cast<std::size_t>(axis);
  const int u = buf[at] | (buf[at + 1] << 8);
  return static_cast<std::int16_t>(u >= 32768 ? u - 65536 : u);
}

}  // namespace

TEST_CASE("scan_codec: Crc32 matches the standard check value and chains like zlib") {
  const std::string check = "123456789";
  const std::vector<std::uint8_t> bytes(check.begin(), check.end());
  CHECK(Crc32(Span<const std::uint8_t>(bytes)) == 0xCBF43926u);
  CHECK(ReferenceCrc32(bytes) == 0xCBF43926u);
  const Span<const std::uint8_t> all(bytes);
  CHECK(Crc32(all.subspan(4, 5), Crc32(all.subspan(0, 4))) == 0xCBF43926u);
  CHECK(Crc32(Span<const std::uint8_t>()) == 0u);
}

TEST_CASE("scan_codec: EncodedScanBytes is 12 header bytes plus 6 per point, at compile time") {
  static_assert(EncodedScanBytes(0) == 12, "header");
  static_assert(EncodedScanBytes(1) == 18, "one point");
  static_assert(EncodedScanBytes(4096) == 12 + 6 * 4096, "typical scan");
  CHECK(EncodedScanBytes(8192) == 49164u);
}

TEST_CASE("scan_codec: random clouds round-trip within 0.5 cm, in order, byte-identical to the reference") {
  std::mt19937 rng(7);
  std::vector<PointXYZI> decoded;
  for (const std::size_t n : {std::size_t{1}, std::size_t{2}, std::size_t{17}, std::size_t{4000}}) {
    for (const float extent_m : {2.0f, 80.0f, 327.0f}) {
      CAPTURE(n);
      CAPTURE(extent_m);
      const std::vector<PointXYZI> cloud = RandomCloud(rng, n, extent_m);
      ScanEncodeInfo info;
      const std::vector<std::uint8_t> buf = EncodeForTest(cloud, &info);
      CHECK(info.num_input == n);
      CHECK(info.num_encoded == n);
      CHECK(info.dropped_nonfinite == 0);
      CHECK(info.dropped_out_of_range == 0);
      CHECK(info.bytes_written == EncodedScanBytes(n));
      CHECK(buf == ReferenceEncode(cloud));

      const Result<std::size_t> got = DecodeScan(Span<const std::uint8_t>(buf), &decoded);
      REQUIRE_MESSAGE(got.ok(), got.status().ToString());
      REQUIRE(*got == n);
      REQUIRE(decoded.size() == n);
      double worst_stored_cm = 0.0;
      double worst_decoded_excess_m = -1.0;
      for (std::size_t i = 0; i < n; ++i) {
        const float in[3] = {cloud[i].x, cloud[i].y, cloud[i].z};
        const float out[3] = {decoded[i].x, decoded[i].y, decoded[i].z};
        for (int k = 0; k < 3; ++k) {
          // The stored integer: exact bound (a float times 100 is exact in double).
          const double err_cm =
              std::fabs(static_cast<double>(StoredCm(buf, i, k)) - static_cast<double>(in[k]) * 100.0);
          worst_stored_cm = std::max(worst_stored_cm, err_cm);
          // The decoded float: 0.5 cm plus the float rounding of the decoded value (half an ulp at |x|).
          const double ulp = static_cast<double>(std::nextafter(std::fabs(out[k]), INFINITY) - std::fabs(out[k]));
          const double excess = std::fabs(static_cast<double>(out[k]) - static_cast<double>(in[k])) - 0.005 - 0.5 * ulp;
          worst_decoded_excess_m = std::max(worst_decoded_excess_m, excess);
        }
        CHECK(decoded[i].intensity == 0.0f);
      }
      CHECK(worst_stored_cm <= 0.5);
      CHECK(worst_decoded_excess_m <= 1e-12);
    }
  }
}

TEST_CASE("scan_codec: Quantisation rounds half away from zero and keeps exactly the int16 centimetre range") {
  // 0.125 m is 12.5 cm exactly (binary fraction): the worst case of the 0.5 cm bound.
  const std::vector<PointXYZI> cloud = {
      {0.125f, -0.125f, 0.0f, 1.0f}, {327.67f, -327.67f, 327.674f, 0.0f},  // +-32767 cm: kept
      {327.68f, 0.0f, 0.0f, 0.0f},                                         // 32768 cm: dropped
      {0.0f, -327.68f, 0.0f, 0.0f},                                        // -32768 cm: dropped (range is symmetric)
      {0.0f, 0.0f, 1.0e6f, 0.0f},    {0.004999f, -0.005001f, 1.0f, 0.0f}};
  ScanEncodeInfo info;
  const std::vector<std::uint8_t> buf = EncodeForTest(cloud, &info);
  CHECK(info.num_encoded == 3);
  CHECK(info.dropped_out_of_range == 3);
  CHECK(info.dropped_nonfinite == 0);
  CHECK(buf == ReferenceEncode(cloud));
  CHECK(StoredCm(buf, 0, 0) == 13);
  CHECK(StoredCm(buf, 0, 1) == -13);
  CHECK(StoredCm(buf, 1, 0) == 32767);
  CHECK(StoredCm(buf, 1, 1) == -32767);
  CHECK(StoredCm(buf, 1, 2) == 32767);
  CHECK(StoredCm(buf, 2, 0) == 0);
  CHECK(StoredCm(buf, 2, 1) == -1);
  CHECK(StoredCm(buf, 2, 2) == 100);
}

TEST_CASE("scan_codec: Non-finite and out-of-range points are dropped and counted, the rest keep their order") {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<PointXYZI> cloud = {{1.0f, 2.0f, 3.0f, 0.0f},    {nan, 0.0f, 0.0f, 0.0f},
                                        {0.0f, -inf, 0.0f, 0.0f},    {400.0f, 0.0f, 0.0f, 0.0f},
                                        {nan, 1000.0f, 0.0f, 0.0f},  // counted once, as non-finite
                                        {4.0f, 5.0f, 6.0f, nan},     // NaN intensity does not matter
                                        {0.0f, 0.0f, -500.0f, 0.0f}, {-7.0f, -8.0f, -9.0f, 0.0f}};
  CHECK(CountEncodablePoints(Span<const PointXYZI>(cloud)) == 3);
  ScanEncodeInfo info;
  const std::vector<std::uint8_t> buf = EncodeForTest(cloud, &info);
  CHECK(info.num_input == 8);
  CHECK(info.num_encoded == 3);
  CHECK(info.dropped_nonfinite == 3);
  CHECK(info.dropped_out_of_range == 2);
  CHECK(buf.size() == EncodedScanBytes(3));
  CHECK(buf == ReferenceEncode(cloud));
  std::vector<PointXYZI> decoded;
  REQUIRE(DecodeScan(Span<const std::uint8_t>(buf), &decoded).ok());
  REQUIRE(decoded.size() == 3);
  CHECK(decoded[0].x == doctest::Approx(1.0));
  CHECK(decoded[1].y == doctest::Approx(5.0));
  CHECK(decoded[2].z == doctest::Approx(-9.0));
}

TEST_CASE("scan_codec: Empty scans encode to the 12-byte header and decode to nothing") {
  for (const std::vector<PointXYZI>& cloud :
       {std::vector<PointXYZI>{}, std::vector<PointXYZI>{{std::numeric_limits<float>::quiet_NaN(), 0, 0, 0}}}) {
    std::vector<std::uint8_t> buf(12);
    const Result<ScanEncodeInfo> info = EncodeScan(Span<const PointXYZI>(cloud), Span<std::uint8_t>(buf));
    REQUIRE(info.ok());
    CHECK(info->bytes_written == 12);
    CHECK(buf == ReferenceEncode(cloud));
    std::vector<PointXYZI> decoded = {{1, 2, 3, 4}};
    const Result<std::size_t> n = DecodeScan(Span<const std::uint8_t>(buf), &decoded);
    REQUIRE(n.ok());
    CHECK(*n == 0);
    CHECK(decoded.empty());
  }
}

TEST_CASE("scan_codec: Encoding needs exactly EncodedScanBytes of the kept points and names both sizes otherwise") {
  std::mt19937 rng(3);
  std::vector<PointXYZI> cloud = RandomCloud(rng, 5, 10.0f);
  cloud.push_back({999.0f, 0, 0, 0});  // dropped: the exact need is for 5 points
  std::vector<std::uint8_t> buf(EncodedScanBytes(5), 0xAB);
  CHECK(EncodeScan(Span<const PointXYZI>(cloud), Span<std::uint8_t>(buf)).ok());
  const Result<ScanEncodeInfo> small = EncodeScan(Span<const PointXYZI>(cloud), Span<std::uint8_t>(buf.data(), 41));
  REQUIRE_FALSE(small.ok());
  CHECK(small.status().code() == StatusCode::kResourceExhausted);
  CHECK(Contains(small.status().message(), "needs 42 bytes (5 points)"));
  CHECK(Contains(small.status().message(), "holds 41 bytes"));
  // A larger buffer is fine; only the front is written.
  std::vector<std::uint8_t> big(100, 0xCD);
  const Result<ScanEncodeInfo> ok = EncodeScan(Span<const PointXYZI>(cloud), Span<std::uint8_t>(big));
  REQUIRE(ok.ok());
  CHECK(ok->bytes_written == 42);
  CHECK(big[42] == 0xCD);
}

TEST_CASE("scan_codec: Truncated and oversized buffers are rejected with the sizes in the message") {
  std::mt19937 rng(11);
  const std::vector<std::uint8_t> buf = EncodeForTest(RandomCloud(rng, 5, 10.0f));
  REQUIRE(buf.size() == 42);
  std::vector<PointXYZI> decoded = {{1, 2, 3, 4}};
  for (std::size_t len = 0; len < buf.size(); ++len) {
    CAPTURE(len);
    const Result<std::size_t> r = DecodeScan(Span<const std::uint8_t>(buf.data(), len), &decoded);
    REQUIRE_FALSE(r.ok());
    CHECK(r.status().code() == StatusCode::kDataLoss);
    CHECK(Contains(r.status().message(), "truncated"));
    CHECK(decoded.empty());
  }
  std::vector<std::uint8_t> longer = buf;
  longer.push_back(0);
  const Result<ScanHeader> r = ParseScanHeader(Span<const std::uint8_t>(longer));
  REQUIRE_FALSE(r.ok());
  CHECK(r.status().code() == StatusCode::kDataLoss);
  CHECK(Contains(r.status().message(), "oversized: the header says 5 points = 42 bytes, the buffer holds 43 bytes"));
}

TEST_CASE("scan_codec: Any single corrupted byte is detected (magic, version, flags, count, CRC, payload)") {
  std::mt19937 rng(5);
  const std::vector<std::uint8_t> buf = EncodeForTest(RandomCloud(rng, 5, 10.0f));
  std::vector<PointXYZI> decoded;
  for (std::size_t at = 0; at < buf.size(); ++at) {
    for (const std::uint8_t flip : {std::uint8_t{0x01}, std::uint8_t{0x80}, std::uint8_t{0xFF}}) {
      CAPTURE(at);
      CAPTURE(static_cast<int>(flip));
      std::vector<std::uint8_t> bad = buf;
      bad[at] ^= flip;
      const Result<std::size_t> r = DecodeScan(Span<const std::uint8_t>(bad), &decoded);
      REQUIRE_FALSE(r.ok());
      CHECK(decoded.empty());
      const std::string& m = r.status().message();
      if (at < 2) {
        CHECK(Contains(m, "magic"));
      } else if (at == 2) {
        CHECK(r.status().code() == StatusCode::kUnimplemented);
        CHECK(Contains(m, "version " + std::to_string(1 ^ flip) + " is not supported"));
      } else if (at == 3) {
        CHECK(r.status().code() == StatusCode::kUnimplemented);
        CHECK(Contains(m, "flags"));
      } else if (at < 8) {
        CHECK(r.status().code() == StatusCode::kDataLoss);  // count no longer matches the size
      } else {
        CHECK(r.status().code() == StatusCode::kDataLoss);
        CHECK(Contains(m, "CRC-32"));
      }
    }
  }
  CHECK(DecodeScan(Span<const std::uint8_t>(buf), &decoded).ok());
}

TEST_CASE("scan_codec: DecodeScan bounds what an untrusted buffer may allocate and reuses the caller's vector") {
  std::mt19937 rng(9);
  const std::vector<std::uint8_t> buf = EncodeForTest(RandomCloud(rng, 100, 10.0f));
  std::vector<PointXYZI> decoded;
  const Result<std::size_t> limited = DecodeScan(Span<const std::uint8_t>(buf), &decoded, 99);
  REQUIRE_FALSE(limited.ok());
  CHECK(limited.status().code() == StatusCode::kResourceExhausted);
  CHECK(Contains(limited.status().message(), "100 points, more than the limit of 99"));
  decoded.reserve(100);
  const PointXYZI* before = decoded.data();
  REQUIRE(DecodeScan(Span<const std::uint8_t>(buf), &decoded, 100).ok());
  CHECK(decoded.data() == before);
  CHECK_FALSE(DecodeScan(Span<const std::uint8_t>(buf), nullptr).ok());
}

}  // namespace commerge
