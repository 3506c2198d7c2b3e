// SPDX-License-Identifier: BSD-3-Clause
// commerge: the bit streams of the compact wire codecs (core/descriptor/compact_batch_codec.hpp,
// compact_pose_codec.hpp): bits LSB-first in each byte, integers as Exp-Golomb codes of order k (EG(k)): for
// v >= 0, u = (v >> k) + 1 written as (bit length of u) - 1 zeros, then u's bits from the most significant down,
// then v's k low bits. A signed value is zig-zagged first (0, -1, 1, -2 ... -> 0, 1, 2, 3 ...).
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/common/span.hpp"

namespace commerge {

/// Leading zeros of one EG code a reader accepts at most (a 64-bit value needs at most 64 - k).
constexpr int kMaxExpGolombZeros = 48;
/// Orders 0..kMaxExpGolombOrder fit the 4 bits a stream header gives each.
constexpr int kExpGolombOrderBits = 4;
constexpr int kMaxExpGolombOrder = (1 << kExpGolombOrderBits) - 1;

inline std::uint64_t ZigZag(std::int64_t s) noexcept {
  return s >= 0 ? static_cast<std::uint64_t>(s) << 1 : (static_cast<std::uint64_t>(-(s + 1)) << 1) | 1u;
}
inline std::int64_t UnZigZag(std::uint64_t v) noexcept {
  return (v & 1u) ? -static_cast<std::int64_t>(v >> 1) - 1 : static_cast<std::int64_t>(v >> 1);
}

inline int BitLength(std::uint64_t u) noexcept {
  int n = 0;
  while (u != 0) {
    ++n;
    u >>= 1;
  }
  return n;
}

/// Bits of EG(k) for v.
inline int ExpGolombBits(std::uint64_t v, int k) noexcept { return 2 * BitLength((v >> k) + 1) - 1 + k; }

/// The order 0..kMaxExpGolombOrder that codes `values` in the fewest bits.
template <typename Container>
int BestExpGolombOrder(const Container& values) {
  int best = 0;
  std::uint64_t best_bits = std::numeric_limits<std::uint64_t>::max();
  for (int k = 0; k <= kMaxExpGolombOrder; ++k) {
    std::uint64_t bits = 0;
    for (std::uint64_t v : values) bits += static_cast<std::uint64_t>(ExpGolombBits(v, k));
    if (bits < best_bits) {
      best_bits = bits;
      best = k;
    }
  }
  return best;
}

/// Appends bits to a byte vector (from its current end, on a byte boundary).
class BitWriter {
 public:
  explicit BitWriter(std::vector<std::uint8_t>* out) : out_(out) {}
  /// The low `bits` bits of `value`, least significant first.
  void Put(std::uint64_t value, int bits) {
    for (int b = 0; b < bits; ++b, ++bit_) {
      if (bit_ % 8 == 0) out_->push_back(0);
      if ((value >> b) & 1u) out_->back() |= static_cast<std::uint8_t>(1u << (bit_ % 8));
    }
  }
  void PutExpGolomb(std::uint64_t v, int k) {
    const std::uint64_t u = (v >> k) + 1;
    const int n = BitLength(u);
    Put(0, n - 1);
    for (int b = n - 1; b >= 0; --b) Put((u >> b) & 1u, 1);
    Put(v & ((std::uint64_t{1} << k) - 1), k);
  }

 private:
  std::vector<std::uint8_t>* out_;
  std::size_t bit_ = 0;
};

/// Reads what BitWriter wrote; every read fails (false) instead of passing the end.
class BitReader {
 public:
  explicit BitReader(Span<const std::uint8_t> bytes) : bytes_(bytes) {}
  bool Get(int bits, std::uint64_t* value) {
    if (bits > 0 && bit_ + static_cast<std::size_t>(bits) > bytes_.size() * 8) return false;
    std::uint64_t v = 0;
    for (int b = 0; b < bits; ++b, ++bit_) v |= static_cast<std::uint64_t>((bytes_[bit_ / 8] >> (bit_ % 8)) & 1u) << b;
    *value = v;
    return true;
  }
  /// False at the end of the bytes or past kMaxExpGolombZeros leading zeros.
  bool GetExpGolomb(int k, std::uint64_t* value) {
    int zeros = 0;
    std::uint64_t bit = 0;
    while (true) {
      if (!Get(1, &bit)) return false;
      if (bit != 0) break;
      if (++zeros > kMaxExpGolombZeros) return false;
    }
    std::uint64_t u = 1;
    for (int i = 0; i < zeros; ++i) {
      if (!Get(1, &bit)) return false;
      u = (u << 1) | bit;
    }
    std::uint64_t low = 0;
    if (!Get(k, &low)) return false;
    *value = ((u - 1) << k) | low;
    return true;
  }
  /// Every byte read and the padding bits of the last one zero.
  bool AtCleanEnd() const {
    if ((bit_ + 7) / 8 != bytes_.size()) return false;
    return bit_ % 8 == 0 || (bytes_[bit_ / 8] >> (bit_ % 8)) == 0;
  }

 private:
  Span<const std::uint8_t> bytes_;
  std::size_t bit_ = 0;
};

}  // namespace commerge
