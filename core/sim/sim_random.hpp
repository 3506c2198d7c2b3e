// SPDX-License-Identifier: BSD-3-Clause
// commerge: the simulator's random numbers: SplitMix64 (Steele et al., OOPSLA 2014) and Box-Muller normals,
// written out here so that a seed gives the same numbers with every standard library (std::*_distribution
// is implementation-defined).
#pragma once

#include <cmath>
#include <cstdint>

namespace commerge {

class SimRandom {
 public:
  explicit SimRandom(std::uint64_t seed) : state_(seed) {}

  std::uint64_t Next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  /// Uniform in [0, 1).
  double Uniform() { return static_cast<double>(Next() >> 11) * (1.0 / 9007199254740992.0); }
  /// Uniform in [lo, hi).
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  /// Uniform integer in [0, n) (n >= 1).
  std::uint64_t Below(std::uint64_t n) { return n <= 1 ? 0 : Next() % n; }
  /// Standard normal (Box-Muller, both values used).
  double Gaussian() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u1 = Uniform();
    while (u1 <= 1e-300) u1 = Uniform();
    const double u2 = Uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(6.283185307179586 * u2);
    has_spare_ = true;
    return r * std::cos(6.283185307179586 * u2);
  }

 private:
  std::uint64_t state_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

/// Mixes several numbers into one 64-bit seed (a robot's, a keyframe's, ...).
inline std::uint64_t MixSeed(std::uint64_t a, std::uint64_t b, std::uint64_t c = 0) {
  SimRandom r(a * 0x9E3779B97F4A7C15ull ^ (b + 0x632BE59BD9B4E019ull) ^ (c * 0xD6E8FEB86659FD93ull));
  r.Next();
  return r.Next();
}

}  // namespace commerge
