// SPDX-License-Identifier: BSD-3-Clause
// Internal to platform/lcm (message_codec.cpp, status_codec.cpp): the bounded-decoding helpers both codecs use.
// Not an API: include it from platform/lcm/*.cpp only.
//
// How a decoder stays bounded: the generated decode() resizes every array to the count it reads (a negative or
// huge count: std::length_error or gigabytes) and assigns every string the length it reads minus one (an int32
// that includes the NUL; it only checks length <= bytes left, so a length of 0 or less becomes an assign() of
// about 2^64 bytes, i.e. std::length_error, and INT32_MIN overflows). So before it runs, the decoder checks the
// fingerprint, then reads every count at its byte offset (fixed-layout types) or walks the buffer field by field
// (WireWalker, for types with strings), checking each count against its MAX_..., each string length against
// 1..kMaxStatusTextBytes + 1, and each array and string against the bytes that are left. After that, decode()
// allocates no more than the buffer holds.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/agent/messages.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge::platform::lcm_detail {

/// InvalidArgument for encoders, DataLoss for decoders: checks shared by both take the one they report.
using MakeError = Status (*)(std::string);

/// Big-endian integer of `bytes` bytes at `offset` (LCM's byte order), sign-extended; the caller checked the
/// size.
inline std::int64_t ReadBe(Span<const std::uint8_t> b, std::size_t offset, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | b[offset + static_cast<std::size_t>(i)];
  const int shift = 64 - 8 * bytes;
  return static_cast<std::int64_t>(v << shift) >> shift;  // sign-extend
}

/// Checks the fingerprint (first, whenever the buffer has one) and that the buffer holds the fixed header up to
/// `header_bytes` (after the fingerprint).
template <typename LcmType>
Status CheckHeader(Span<const std::uint8_t> bytes, std::size_t header_bytes, const char* type) {
  if (bytes.size() >= 8 && ReadBe(bytes, 0, 8) != LcmType::getHash()) {
    return DataLoss(std::string(type) + ": fingerprint does not match (another message type or another layout "
                                        "version of commerge)");
  }
  if (bytes.size() < 8 + header_bytes) {
    return DataLoss(std::string(type) + ": " + std::to_string(bytes.size()) + " bytes is shorter than its header");
  }
  return Status::Ok();
}

/// The buffer must hold `needed` bytes for the counts it announces: checked before the decoder allocates.
inline Status CheckRoom(Span<const std::uint8_t> bytes, std::int64_t needed, const char* type) {
  if (static_cast<std::int64_t>(bytes.size()) < needed) {
    return DataLoss(std::string(type) + ": " + std::to_string(bytes.size()) + " bytes cannot hold the " +
                    std::to_string(needed) + " its counts announce");
  }
  return Status::Ok();
}

inline Status CheckCount(std::int64_t value, std::int64_t max, const char* type, const char* field) {
  if (value < 0 || value > max) {
    return DataLoss(std::string(type) + ": " + field + " = " + std::to_string(value) + " is outside 0.." +
                    std::to_string(max));
  }
  return Status::Ok();
}

/// Runs the generated decoder (after the bounds checks) and refuses a buffer it does not consume exactly.
template <typename LcmType>
Status DecodeChecked(Span<const std::uint8_t> bytes, LcmType* msg, const char* type) {
  const int n = msg->decode(bytes.data(), 0, static_cast<int>(bytes.size()));
  if (n < 0) {
    return DataLoss(std::string(type) + ": truncated or malformed (" + std::to_string(bytes.size()) + " bytes)");
  }
  if (static_cast<std::size_t>(n) != bytes.size()) {
    return DataLoss(std::string(type) + ": " + std::to_string(bytes.size() - static_cast<std::size_t>(n)) +
                    " trailing bytes");
  }
  return Status::Ok();
}

template <typename LcmType>
Status EncodeInto(const LcmType& msg, std::vector<std::uint8_t>* out, const char* type) {
  const int size = msg.getEncodedSize();
  out->resize(static_cast<std::size_t>(size));
  if (msg.encode(out->data(), 0, size) != size) {
    out->clear();
    return InvalidArgument(std::string(type) + ": LCM encoding failed");
  }
  return Status::Ok();
}

/// "field[i]" and "field[i].member": the names errors give array elements.
inline std::string Indexed(const char* field, std::size_t i) {
  return std::string(field) + "[" + std::to_string(i) + "]";
}
inline std::string Indexed(const char* field, std::size_t i, const char* member) {
  return Indexed(field, i) + "." + member;
}

/// A robot id in 0..kMaxRobotId; `field` names it ("robot_id", "pairs[3].alpha").
inline Status CheckRobotIdAs(MakeError make, std::int64_t robot_id, const char* type, const std::string& field) {
  if (robot_id < 0 || robot_id > kMaxRobotId) {
    return make(std::string(type) + ": " + field + " " + std::to_string(robot_id) + " is outside 0.." +
                std::to_string(kMaxRobotId));
  }
  return Status::Ok();
}
inline Status CheckRobotId(int robot_id, const char* type) {
  return CheckRobotIdAs(InvalidArgument, robot_id, type, "robot_id");
}
inline Status CheckDecodedRobotId(int robot_id, const char* type) {
  return CheckRobotIdAs(DataLoss, robot_id, type, "robot_id");
}

/// An unsigned value that travels as int32 (LCM has no unsigned types).
inline Status ToWireInt32(std::uint32_t value, const char* type, const std::string& field, std::int32_t* out) {
  if (value > static_cast<std::uint32_t>(std::numeric_limits<std::int32_t>::max())) {
    return InvalidArgument(std::string(type) + ": " + field + " = " + std::to_string(value) +
                           " does not fit int32 (at most 2147483647)");
  }
  *out = static_cast<std::int32_t>(value);
  return Status::Ok();
}
/// Back: a negative wire value is refused.
inline Status FromWireInt32(std::int32_t value, const char* type, const std::string& field, std::uint32_t* out) {
  if (value < 0) {
    return DataLoss(std::string(type) + ": " + field + " = " + std::to_string(value) + " is negative");
  }
  *out = static_cast<std::uint32_t>(value);
  return Status::Ok();
}

/// An LCM boolean / 0-or-1 flag on the wire.
inline Status CheckFlag(std::int64_t value, MakeError make, const char* type, const std::string& field) {
  if (value != 0 && value != 1) {
    return make(std::string(type) + ": " + field + " = " + std::to_string(value) + " is not 0 or 1");
  }
  return Status::Ok();
}

/// A string field: at most kMaxStatusTextBytes bytes and no NUL (LCM strings are NUL-terminated).
inline Status CheckText(const std::string& text, MakeError make, const char* type, const std::string& field) {
  if (text.size() > kMaxStatusTextBytes || text.find('\0') != std::string::npos) {
    return make(std::string(type) + ": " + field + " (" + std::to_string(text.size()) +
                " bytes) is longer than " + std::to_string(kMaxStatusTextBytes) + " bytes or contains a NUL");
  }
  return Status::Ok();
}

/// A pose as LCM float arrays: translation x, y, z [m] and the unit quaternion w, x, y, z. The caller checked
/// that T is finite.
inline void PoseToWire(const Eigen::Isometry3d& T, std::vector<float>* t, std::vector<float>* q) {
  const Eigen::Quaterniond u = Eigen::Quaterniond(T.linear()).normalized();
  *q = {static_cast<float>(u.w()), static_cast<float>(u.x()), static_cast<float>(u.y()), static_cast<float>(u.z())};
  *t = {static_cast<float>(T.translation().x()), static_cast<float>(T.translation().y()),
        static_cast<float>(T.translation().z())};
}

/// Back: false for a non-finite value or a quaternion whose norm is off 1 by more than 1e-3 (the rotation is
/// then renormalised, so it is exactly orthonormal).
inline bool PoseFromWire(const std::vector<float>& t, const std::vector<float>& q, Eigen::Isometry3d* T) {
  if (t.size() != 3 || q.size() != 4) return false;
  const Eigen::Vector4d qv(static_cast<double>(q[0]), static_cast<double>(q[1]), static_cast<double>(q[2]),
                           static_cast<double>(q[3]));
  const Eigen::Vector3d tv(static_cast<double>(t[0]), static_cast<double>(t[1]), static_cast<double>(t[2]));
  if (!qv.allFinite() || !tv.allFinite() || std::abs(qv.norm() - 1.0) > 1e-3) return false;
  *T = Eigen::Isometry3d::Identity();
  T->linear() = Eigen::Quaterniond(qv[0], qv[1], qv[2], qv[3]).normalized().toRotationMatrix();
  T->translation() = tv;
  return true;
}

/// Walks an LCM buffer field by field before the generated decoder runs (types with strings, whose later
/// fields sit at no fixed offset). Every step checks the bytes left; counts are checked against their MAX and
/// against the bytes their elements need at the least; a string's int32 length (which includes the NUL) must
/// be 1..kMaxStatusTextBytes + 1, fit the buffer, and end the string at its first NUL. The first failure
/// sticks: later steps do nothing and Count() returns 0, so a decoder reads as its layout and checks Finish().
class WireWalker {
 public:
  /// Starts after the 8-byte fingerprint, which the caller checked.
  WireWalker(Span<const std::uint8_t> bytes, const char* type) : bytes_(bytes), type_(type) {
    if (bytes_.size() < pos_) {
      status_ = DataLoss(std::string(type_) + ": " + std::to_string(bytes_.size()) + " bytes is shorter than its header");
      pos_ = bytes_.size();
    }
  }

  /// Fixed-size fields, `what` names them.
  void Skip(std::int64_t n, const char* what) {
    if (!status_.ok()) return;
    if (n < 0 || n > Left()) {
      status_ = DataLoss(std::string(type_) + ": truncated in " + what + " (" + std::to_string(n) +
                         " bytes needed at offset " + std::to_string(pos_) + ", " + std::to_string(Left()) +
                         " left)");
      return;
    }
    pos_ += static_cast<std::size_t>(n);
  }

  /// A count of `width` bytes (2 or 4) in 0..max, whose elements need at least `min_element_bytes` each.
  std::int64_t Count(int width, std::int64_t max, const char* field, std::int64_t min_element_bytes) {
    const std::size_t at = pos_;
    Skip(width, field);
    if (!status_.ok()) return 0;
    const std::int64_t n = ReadBe(bytes_, at, width);
    if (Status st = CheckCount(n, max, type_, field); !st.ok()) {
      status_ = st;
      return 0;
    }
    if (n * min_element_bytes > Left()) {
      status_ = DataLoss(std::string(type_) + ": " + std::to_string(bytes_.size()) + " bytes cannot hold the " +
                         field + " = " + std::to_string(n) + " elements it announces (" +
                         std::to_string(n * min_element_bytes) + " bytes at offset " + std::to_string(pos_) +
                         ", " + std::to_string(Left()) + " left)");
      return 0;
    }
    return n;
  }

  /// One string; `field` names it.
  void String(const std::string& field) {
    const std::size_t at = pos_;
    Skip(4, field.c_str());
    if (!status_.ok()) return;
    const std::int64_t len = ReadBe(bytes_, at, 4);
    const std::int64_t max = static_cast<std::int64_t>(kMaxStatusTextBytes) + 1;
    if (len < 1 || len > max) {
      status_ = DataLoss(std::string(type_) + ": " + field + " has length " + std::to_string(len) +
                         " (with its NUL), outside 1.." + std::to_string(max));
      return;
    }
    Skip(len, field.c_str());
    if (!status_.ok()) return;
    const std::uint8_t* text = bytes_.data() + pos_ - static_cast<std::size_t>(len);
    if (std::memchr(text, 0, static_cast<std::size_t>(len)) != text + len - 1) {
      status_ = DataLoss(std::string(type_) + ": " + field + " is not a NUL-terminated string of " +
                         std::to_string(len - 1) + " bytes");
    }
  }

  /// `n` strings of an array named `field` (field[i]).
  void Strings(std::int64_t n, const char* field) {
    for (std::int64_t i = 0; i < n && status_.ok(); ++i) String(std::string(field) + "[" + std::to_string(i) + "]");
  }

  /// The first failure, or trailing bytes after the layout.
  Status Finish() const {
    if (!status_.ok()) return status_;
    if (pos_ != bytes_.size()) {
      return DataLoss(std::string(type_) + ": " + std::to_string(bytes_.size() - pos_) + " trailing bytes");
    }
    return Status::Ok();
  }

 private:
  std::int64_t Left() const { return static_cast<std::int64_t>(bytes_.size() - pos_); }

  Span<const std::uint8_t> bytes_;
  const char* type_;
  std::size_t pos_ = 8;
  Status status_;
};

}  // namespace commerge::platform::lcm_detail
