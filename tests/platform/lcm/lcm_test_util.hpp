// SPDX-License-Identifier: BSD-3-Clause
// Helpers shared by the LCM codec tests: big-endian bytes read and patched by hand (independently of the codecs),
// the generated types' own encode/decode as the reference, error-message checks, and the hostile-buffer sweeps
// (every truncation, trailing bytes, counts and string lengths patched beyond MAX or the buffer) every decoder
// must survive, and a fully set robot_status_t.
#pragma once

#include <doctest/doctest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include <lcm/lcm-cpp.hpp>

#include <commerge/robot_status_t.hpp>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "tests/support/pose_errors.hpp"
#include "tests/support/strings.hpp"

namespace commerge::platform {

using Buffer = std::vector<std::uint8_t>;

// Raw LCM subscription callback: keeps the bytes LCM delivered, with their channel.
inline void KeepBytes(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
                      std::vector<std::pair<std::string, Buffer>>* got) {
  const auto* p = static_cast<const std::uint8_t*>(rbuf->data);
  got->emplace_back(channel, Buffer(p, p + rbuf->data_size));
}

// ---- independent byte helpers (LCM is big-endian) ----

inline std::int64_t GetBe(const Buffer& b, std::size_t offset, int bytes) {
  REQUIRE(offset + static_cast<std::size_t>(bytes) <= b.size());
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | b[offset + static_cast<std::size_t>(i)];
  if (bytes < 8 && (v >> (8 * bytes - 1)) != 0) v |= ~std::uint64_t{0} << (8 * bytes);  // sign-extend
  return static_cast<std::int64_t>(v);
}

inline void PutBe(Buffer* b, std::size_t offset, std::uint64_t v, int bytes) {
  REQUIRE(offset + static_cast<std::size_t>(bytes) <= b->size());
  for (int i = 0; i < bytes; ++i) {
    (*b)[offset + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (8 * (bytes - 1 - i)));
  }
}
inline void PutBe32(Buffer* b, std::size_t offset, std::uint32_t v) { PutBe(b, offset, v, 4); }
inline void PutBe16(Buffer* b, std::size_t offset, std::uint16_t v) { PutBe(b, offset, v, 2); }

inline float GetBeFloat(const Buffer& b, std::size_t offset) {
  const auto bits = static_cast<std::uint32_t>(GetBe(b, offset, 4));
  float f = 0.0f;
  std::memcpy(&f, &bits, 4);
  return f;
}

inline void PutBeFloat(Buffer* b, std::size_t offset, float f) {
  std::uint32_t bits = 0;
  std::memcpy(&bits, &f, 4);
  PutBe32(b, offset, bits);
}

inline double GetBeDouble(const Buffer& b, std::size_t offset) {
  const auto bits = static_cast<std::uint64_t>(GetBe(b, offset, 8));
  double d = 0.0;
  std::memcpy(&d, &bits, 8);
  return d;
}

inline void PutBeDouble(Buffer* b, std::size_t offset, double d) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &d, 8);
  PutBe(b, offset, bits, 8);
}

inline Span<const std::uint8_t> S(const Buffer& b) { return Span<const std::uint8_t>(b.data(), b.size()); }

using test::Contains;

// ---- the generated type's own encoding ----

template <typename LcmType>
Buffer LcmEncode(const LcmType& msg) {
  Buffer b(static_cast<std::size_t>(msg.getEncodedSize()));
  REQUIRE(msg.encode(b.data(), 0, static_cast<int>(b.size())) == static_cast<int>(b.size()));
  return b;
}

template <typename LcmType>
LcmType LcmDecode(const Buffer& b) {
  LcmType msg;
  REQUIRE(msg.decode(b.data(), 0, static_cast<int>(b.size())) == static_cast<int>(b.size()));
  return msg;
}

// ---- error checks ----

template <typename T>
void CheckDataLoss(const Result<T>& r, const std::vector<std::string>& parts) {
  REQUIRE_FALSE(r.ok());
  CHECK(r.status().code() == StatusCode::kDataLoss);
  for (const std::string& part : parts) {
    INFO("message: ", r.status().message(), " expected to contain: ", part);
    CHECK(Contains(r.status().message(), part));
  }
}

inline void CheckInvalid(const Status& st, const std::vector<std::string>& parts) {
  CHECK(st.code() == StatusCode::kInvalidArgument);
  for (const std::string& part : parts) {
    INFO("message: ", st.message(), " expected to contain: ", part);
    CHECK(Contains(st.message(), part));
  }
}

// ---- hostile-buffer sweeps ----

/// Every truncation 0..size-1 of a valid buffer is refused with DataLoss (each an exact-size heap copy, so a read
/// past the end is a real overread that sanitizers see). `decode` is a decoder taking Span<const uint8_t>.
template <typename Decode>
void CheckEveryTruncationRefused(const Buffer& full, Decode decode, const char* type) {
  REQUIRE(decode(S(full)).ok());
  std::size_t refused = 0;
  for (std::size_t len = 0; len < full.size(); ++len) {
    const Buffer cut(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(len));
    const auto r = decode(S(cut));
    if (r.ok() || r.status().code() != StatusCode::kDataLoss) {
      INFO(type, " truncated to ", len, " of ", full.size(), " bytes: ", r.status().ToString());
      CHECK_FALSE(r.ok());
      CHECK(r.status().code() == StatusCode::kDataLoss);
    } else {
      ++refused;
    }
  }
  INFO(type, ": ", refused, " of ", full.size(), " truncations refused");
  CHECK(refused == full.size());
}

/// 1 and 8 bytes after a valid buffer are refused, naming the type and "trailing".
template <typename Decode>
void CheckTrailingBytesRefused(const Buffer& full, Decode decode, const char* type) {
  for (std::size_t extra : {std::size_t{1}, std::size_t{8}}) {
    Buffer b = full;
    b.insert(b.end(), extra, 0);
    CheckDataLoss(decode(S(b)), {type, "trailing"});
  }
}

// A count field (big-endian, `width` bytes at `offset`, holding `expected` in `valid`) patched outside 0..max is
// refused naming it; patched to max, more elements than the buffer holds, it is refused as well. Either way
// before the generated decoder allocates (a patched 2^31 would otherwise ask for gigabytes).
template <typename Decode>
void CheckPatchedCount(const Buffer& valid, std::size_t offset, int width, std::int64_t expected, std::int64_t max,
                       const char* field, Decode decode) {
  INFO("count ", field, " at offset ", offset);
  REQUIRE(GetBe(valid, offset, width) == expected);
  REQUIRE(decode(S(valid)).ok());
  const std::uint64_t top = width == 2 ? 0x7fffu : 0x7fffffffu;
  const std::uint64_t minus_one = width == 2 ? 0xffffu : 0xffffffffu;
  for (std::uint64_t v : {static_cast<std::uint64_t>(max + 1), top, minus_one, top + 1}) {
    INFO("patched to ", v);
    Buffer b = valid;
    PutBe(&b, offset, v, width);
    CheckDataLoss(decode(S(b)), {field, "outside 0.." + std::to_string(max)});
  }
  Buffer b = valid;
  PutBe(&b, offset, static_cast<std::uint64_t>(max), width);
  CheckDataLoss(decode(S(b)), {field, "cannot hold"});
}

// A string's int32 length (with its NUL, at `offset`, the string `text` in `valid`) patched to 0, negative,
// beyond 257, beyond the buffer, or so that the NUL is not where the length says, is refused naming the field.
template <typename Decode>
void CheckPatchedStringLength(const Buffer& valid, std::size_t offset, const std::string& text, const char* field,
                              Decode decode) {
  INFO("string ", field, " at offset ", offset);
  REQUIRE(GetBe(valid, offset, 4) == static_cast<std::int64_t>(text.size() + 1));
  REQUIRE(offset + 4 + text.size() + 1 <= valid.size());
  REQUIRE(std::memcmp(valid.data() + offset + 4, text.data(), text.size()) == 0);
  REQUIRE(valid[offset + 4 + text.size()] == 0);
  for (std::uint32_t v : {0u, 0xffffffffu, 0x80000000u, 258u, 0x7fffffffu}) {
    INFO("length patched to ", v);
    Buffer b = valid;
    PutBe32(&b, offset, v);
    CheckDataLoss(decode(S(b)), {field, "length"});
  }
  if (offset + 4 + 257 > valid.size()) {  // a legal length the buffer cannot hold
    Buffer b = valid;
    PutBe32(&b, offset, 257);
    CheckDataLoss(decode(S(b)), {field});
  }
  if (!text.empty()) {  // one byte shorter: the last byte it covers is not the NUL
    Buffer b = valid;
    PutBe32(&b, offset, static_cast<std::uint32_t>(text.size()));
    CheckDataLoss(decode(S(b)), {field});
  }
  Buffer b = valid;  // the NUL replaced
  b[offset + 4 + text.size()] = 'x';
  CheckDataLoss(decode(S(b)), {field, "NUL"});
}

// ---- a generated message with every field set ----

/// A robot_status_t with two modules and every field set (its generated encode/decode as the reference).
inline commerge::robot_status_t SampleRobotStatusT() {
  commerge::robot_status_t s{};
  s.utime = 1763800000123456;
  s.robot_id = 2;
  s.session = 1763799999000002;
  s.peak_rss_bytes = 300LL << 20;
  s.budget_total_bytes = 275LL << 20;
  s.budget_limit_bytes = 2650LL << 20;
  s.num_modules = 2;
  s.module_name = {"scan_store", "descriptor_db"};
  s.module_budget_bytes = {160LL << 20, 10LL << 20};
  s.module_used_bytes = {12345678, 4096};
  s.module_high_water_bytes = {23456789, 8192};
  s.keyframes = 120;
  s.keyframes_acked = 100;
  s.queued_keyframes = 20;
  s.queued_poses = 3;
  s.queued_chunks = 41;
  s.bytes_sent = 123456789;
  s.bytes_resent = 4567;
  s.request_id = 5;
  s.state = "sending scans";
  return s;
}

// ---- poses ----

using test::RotationErrorRad;

inline Eigen::Isometry3d Pose(double angle, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

/// Within float precision: translation to 1e-5 relative (at least 1e-5 m), rotation to 1e-5 rad.
inline bool NearPose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const double scale = std::max(1.0, b.translation().cwiseAbs().maxCoeff());
  return (a.translation() - b.translation()).cwiseAbs().maxCoeff() < 1e-5 * scale &&
         RotationErrorRad(a.linear(), b.linear()) < 1e-5;
}

}  // namespace commerge::platform
