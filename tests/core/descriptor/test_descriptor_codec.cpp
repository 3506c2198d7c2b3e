// SPDX-License-Identifier: BSD-3-Clause
// Keyframe record codec (92 bytes) and float16 arrays: byte layout, round trips with derived error bounds,
// rejection of bad inputs and garbage, IEEE half rounding against a brute-force nearest-value search.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "core/descriptor/descriptor_codec.hpp"
#include "tests/core/descriptor/descriptor_test_util.hpp"
#include "core/descriptor/solid.hpp"
#include "core/geometry/angles.hpp"
#include "tests/support/pose_errors.hpp"

namespace commerge {
namespace {

using test::RotationErrorRad;


using Descriptor = std::array<float, kKeyframeDescriptorDim>;
using Record = std::array<std::uint8_t, kKeyframeRecordBytes>;

// r = sqrt(40) / (2 * 16383): the largest L2 error of the max-scaled codes (see descriptor_codec.hpp).
const double kCodeRadius = std::sqrt(40.0) / (2.0 * 16383.0);
// Float rounding of unit vectors (2^-24 relative per element, 40 elements) plus the cos -> d cancellation.
constexpr double kFloatSlack = 1e-6;

Descriptor Normalized(const std::vector<double>& v) {
  double n = 0;
  for (double x : v) n += x * x;
  Descriptor d{};
  for (std::size_t i = 0; i < d.size(); ++i) d[i] = static_cast<float>(v[i] / std::sqrt(n));
  return d;
}

double MaxElement(const Descriptor& d) {
  double m = 0, n = 0;
  for (float v : d) m = std::max(m, static_cast<double>(v)), n += static_cast<double>(v) * static_cast<double>(v);
  return m / std::sqrt(n);
}

// Random non-negative descriptors of several shapes: dense uniform, sparse, one dominant ring (max element
// near 1, the worst case of the bound), smooth SOLiD-like profiles.
Descriptor RandomDescriptor(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> v(kKeyframeDescriptorDim, 0.0);
  switch (rng() % 4) {
    case 0:
      for (double& x : v) x = u(rng);
      break;
    case 1:
      for (double& x : v) x = u(rng) < 0.2 ? u(rng) : 0.0;
      v[rng() % v.size()] += 0.1;
      break;
    case 2:
      for (double& x : v) x = 0.01 * u(rng);
      v[rng() % v.size()] = 1.0;
      break;
    default: {
      const double peak = 3 + 20 * u(rng), width = 2 + 10 * u(rng);
      for (std::size_t i = 0; i < v.size(); ++i) {
        v[i] = 1000 * std::exp(-std::pow((static_cast<double>(i) - peak) / width, 2)) * (0.8 + 0.4 * u(rng));
      }
    }
  }
  return Normalized(v);
}

Eigen::Isometry3d RandomPose(std::mt19937& rng, double extent_m) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> u(-extent_m, extent_m);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  q.normalize();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.toRotationMatrix();
  T.translation() = Eigen::Vector3d(u(rng), u(rng), u(rng) * 0.01);
  return T;
}


KeyframeRecord MakeRecord(std::uint32_t index, const Eigen::Isometry3d& T, const Descriptor& d) {
  KeyframeRecord r;
  r.keyframe_index = index;
  r.T_map_sensor = T;
  r.descriptor = d;
  r.descriptor_valid = true;
  return r;
}

std::uint64_t Field48(const Record& rec) {
  std::uint64_t v = 0;
  for (int i = 0; i < 6; ++i) v |= static_cast<std::uint64_t>(rec[16 + i]) << (8 * i);
  return v;
}

TEST_CASE("keyframe record: size and byte layout") {
  CHECK(kKeyframeRecordBytes == 92);
  CHECK(kKeyframeRecordBytes <= 96);
  Descriptor d{};
  d[0] = 1.0f;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(1.0, -2.0, 0.5);
  T.linear() = Eigen::AngleAxisd(60.0 * kPi / 180.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
  Record rec{};
  REQUIRE(EncodeKeyframeRecord(MakeRecord(0x01020304u, T, d), AsSpan(rec)).ok());
  // index, little-endian
  CHECK(rec[0] == 0x04);
  CHECK(rec[1] == 0x03);
  CHECK(rec[2] == 0x02);
  CHECK(rec[3] == 0x01);
  // 1.0f = 0x3f800000, -2.0f = 0xc0000000, 0.5f = 0x3f000000, little-endian
  const std::uint8_t t_bytes[12] = {0, 0, 0x80, 0x3f, 0, 0, 0, 0xc0, 0, 0, 0, 0x3f};
  CHECK(std::memcmp(rec.data() + 4, t_bytes, 12) == 0);
  // q = (cos 30, sin 30, 0, 0): w is dropped (index 0); x, y, z follow as 15-bit codes.
  const std::uint64_t f = Field48(rec);
  CHECK((f & 3u) == 0);
  CHECK(((f >> 2) & 0x7fff) == static_cast<std::uint64_t>(std::lround(0.5 * std::sqrt(2.0) * 16383)));
  CHECK(((f >> 17) & 0x7fff) == 0);
  CHECK(((f >> 32) & 0x7fff) == 0);
  CHECK((f >> 47) == 0);  // reserved
  // descriptor e_0: code 0 = 16383 at bits 0..13 of byte 22
  CHECK(rec[22] == 0xff);
  CHECK(rec[23] == 0x3f);
  CHECK(std::all_of(rec.begin() + 24, rec.end(), [](std::uint8_t b) { return b == 0; }));

  // e_1: code 1 = 16383 at bits 14..27
  d[0] = 0.0f;
  d[1] = 1.0f;
  REQUIRE(EncodeKeyframeRecord(MakeRecord(0, Eigen::Isometry3d::Identity(), d), AsSpan(rec)).ok());
  CHECK(std::all_of(rec.begin(), rec.begin() + 22, [](std::uint8_t b) { return b == 0; }));  // identity pose
  CHECK(rec[22] == 0x00);
  CHECK(rec[23] == 0xc0);
  CHECK(rec[24] == 0xff);
  CHECK(rec[25] == 0x0f);
  // e_39: the last code ends at bit 559 = the last bit of byte 91
  d[1] = 0.0f;
  d[39] = 1.0f;
  REQUIRE(EncodeKeyframeRecord(MakeRecord(0, Eigen::Isometry3d::Identity(), d), AsSpan(rec)).ok());
  CHECK(rec[91] == 0xff);
  CHECK(rec[90] == 0xfc);
  const auto back = DecodeKeyframeRecord(AsSpan(rec));
  REQUIRE(back.ok());
  CHECK(back->descriptor[39] == 1.0f);
  CHECK(back->descriptor_valid);

  // A scaled pose with a 180-degree rotation about z: q = (0, 0, 0, 1), z dropped (index 3).
  T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  REQUIRE(EncodeKeyframeRecord(MakeRecord(0, T, d), AsSpan(rec)).ok());
  CHECK((Field48(rec) & 3u) == 3);
}

TEST_CASE("keyframe record round trip: random descriptors and poses, derived error bounds") {
  std::mt19937 rng(2024);
  constexpr int kN = 3000;
  std::vector<Descriptor> in(kN), out(kN);
  std::vector<double> max_el(kN);
  double max_t_err = 0, max_rot_err = 0, max_vec_err_ratio = 0;
  Record rec{};
  for (int i = 0; i < kN; ++i) {
    in[i] = RandomDescriptor(rng);
    max_el[i] = MaxElement(in[i]);
    const Eigen::Isometry3d T = RandomPose(rng, 10000.0);  // coordinates up to 10 km
    const std::uint32_t index = i == 0 ? 0xffffffffu : static_cast<std::uint32_t>(rng());
    REQUIRE(EncodeKeyframeRecord(MakeRecord(index, T, in[i]), AsSpan(rec)).ok());
    const auto dec = DecodeKeyframeRecord(AsSpan(rec));
    REQUIRE_MESSAGE(dec.ok(), dec.status().ToString());
    CHECK(dec->keyframe_index == index);
    CHECK(dec->descriptor_valid);
    out[i] = dec->descriptor;
    // Pose: float32 translation (<= half an ulp: 0.49 mm below 16 km), smallest-three rotation.
    const double t_err = (dec->T_map_sensor.translation() - T.translation()).cwiseAbs().maxCoeff();
    max_t_err = std::max(max_t_err, t_err);
    const double rot_err = RotationErrorRad(dec->T_map_sensor.linear(), T.linear());
    max_rot_err = std::max(max_rot_err, rot_err);
    const Eigen::Matrix3d R = dec->T_map_sensor.linear();
    CHECK((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-12);
    // Descriptor: unit length again, within asin(m r) of the original direction.
    double n2 = 0, e2 = 0;
    for (std::size_t k = 0; k < kKeyframeDescriptorDim; ++k) {
      const double o = static_cast<double>(out[i][k]), a = static_cast<double>(in[i][k]);
      CHECK(o >= 0.0);
      n2 += o * o;
      e2 += (o - a) * (o - a);
    }
    CHECK(std::fabs(std::sqrt(n2) - 1.0) < 1e-6);
    const double bound = std::asin(max_el[i] * kCodeRadius) + kFloatSlack;
    CHECK(std::sqrt(e2) <= bound);
    max_vec_err_ratio = std::max(max_vec_err_ratio, std::sqrt(e2) / bound);
  }
  CHECK(max_t_err < 1e-3);
  CHECK(max_t_err <= 4.9e-4);
  CHECK(max_rot_err < 1e-3);

  // Pair distances: |d_decoded - d_true| <= asin(m_a r) + asin(m_b r) (+ float slack), on random pairs
  // and on near-duplicate pairs (the regime where thresholds 0.01 .. 0.10 decide).
  double max_dd = 0, sum_dd = 0, max_ratio = 0;
  int pairs = 0;
  const auto check_pair = [&](const Descriptor& a, const Descriptor& b, const Descriptor& ad, const Descriptor& bd,
                              double ma, double mb) {
    const double d_true = SolidDistance(Span<const float>(a.data(), a.size()), Span<const float>(b.data(), b.size()));
    const double d_dec =
        SolidDistance(Span<const float>(ad.data(), ad.size()), Span<const float>(bd.data(), bd.size()));
    const double dd = std::fabs(d_dec - d_true);
    const double bound = std::asin(ma * kCodeRadius) + std::asin(mb * kCodeRadius) + 2 * kFloatSlack;
    CHECK(dd <= bound);
    max_ratio = std::max(max_ratio, dd / bound);
    sum_dd += dd;
    ++pairs;
    return dd;
  };
  for (int i = 0; i + 1 < kN; ++i) {
    max_dd = std::max(max_dd, check_pair(in[i], in[i + 1], out[i], out[i + 1], max_el[i], max_el[i + 1]));
  }
  std::normal_distribution<double> noise(0.0, 1.0);
  double max_dd_near = 0;
  for (int i = 0; i < 1000; ++i) {
    const Descriptor& a = in[i];
    std::vector<double> v(kKeyframeDescriptorDim);
    const double sigma = 0.002 * (1 + i % 10);  // d from ~0.003 to ~0.1
    for (std::size_t k = 0; k < v.size(); ++k) v[k] = std::max(0.0, static_cast<double>(a[k]) + sigma * noise(rng));
    const Descriptor b = Normalized(v);
    REQUIRE(EncodeKeyframeRecord(MakeRecord(1, Eigen::Isometry3d::Identity(), b), AsSpan(rec)).ok());
    const auto bd = DecodeKeyframeRecord(AsSpan(rec));
    REQUIRE(bd.ok());
    max_dd_near = std::max(max_dd_near, check_pair(a, b, out[i], bd->descriptor, max_el[i], MaxElement(b)));
  }
  max_dd = std::max(max_dd, max_dd_near);
  MESSAGE("codec: " << pairs << " pairs, max |dd| " << max_dd << " (near-duplicate pairs " << max_dd_near
                    << "), mean " << sum_dd / pairs << ", max |dd| / bound " << max_ratio
                    << ", worst-case bound 2 asin(r) = " << 2 * std::asin(kCodeRadius)
                    << "; max vector error / bound " << max_vec_err_ratio << "; max translation error "
                    << max_t_err * 1e3 << " mm at 10 km; max rotation error " << max_rot_err << " rad");
  CHECK(max_dd < 4e-4);  // 2 asin(r) + slack: 25x below tau = 0.01
}

TEST_CASE("keyframe record: quaternion edge cases (ties, sign, 180-degree turns)") {
  const std::vector<Eigen::Quaterniond> qs = {
      Eigen::Quaterniond(1, 0, 0, 0),          Eigen::Quaterniond(0, 1, 0, 0),
      Eigen::Quaterniond(0, 0, 1, 0),          Eigen::Quaterniond(0, 0, 0, 1),
      Eigen::Quaterniond(0.5, 0.5, 0.5, 0.5),  Eigen::Quaterniond(-0.5, 0.5, -0.5, 0.5),
      Eigen::Quaterniond(std::sqrt(0.5), 0, 0, std::sqrt(0.5)), Eigen::Quaterniond(0, std::sqrt(0.5), -std::sqrt(0.5), 0),
      Eigen::Quaterniond(-0.9, 0.3, 0.3, 0.1), Eigen::Quaterniond(1e-9, 1, 1e-9, -1e-9),
  };
  Descriptor d{};
  d[5] = 1.0f;
  Record rec{};
  for (Eigen::Quaterniond q : qs) {
    q.normalize();
    CAPTURE(q.coeffs().transpose());
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = q.toRotationMatrix();
    REQUIRE(EncodeKeyframeRecord(MakeRecord(7, T, d), AsSpan(rec)).ok());
    const auto dec = DecodeKeyframeRecord(AsSpan(rec));
    REQUIRE_MESSAGE(dec.ok(), dec.status().ToString());
    CHECK(RotationErrorRad(dec->T_map_sensor.linear(), T.linear()) < 2e-4);
  }
}

TEST_CASE("keyframe record: encoder refuses invalid input") {
  Descriptor d{};
  d[3] = 0.6f;
  d[4] = 0.8f;
  const KeyframeRecord good = MakeRecord(3, Eigen::Isometry3d::Identity(), d);
  Record rec{};
  REQUIRE(EncodeKeyframeRecord(good, AsSpan(rec)).ok());

  const auto expect = [&](const KeyframeRecord& r, const char* words) {
    const Status s = EncodeKeyframeRecord(r, AsSpan(rec));
    CHECK_FALSE(s.ok());
    CHECK(s.code() == StatusCode::kInvalidArgument);
    CHECK_MESSAGE(s.message().find(words) != std::string::npos, s.message());
  };
  KeyframeRecord r = good;
  r.descriptor_valid = false;
  expect(r, "invalid");
  r = good;
  r.descriptor.fill(0.0f);
  expect(r, "norm");
  r = good;
  r.descriptor[3] = -0.6f;
  expect(r, ">= 0");
  r = good;
  r.descriptor[0] = std::numeric_limits<float>::quiet_NaN();
  expect(r, "finite");
  r = good;
  r.descriptor[3] = 6.0f;
  r.descriptor[4] = 8.0f;  // raw, not unit
  expect(r, "unit-normalised");
  r = good;
  r.T_map_sensor.translation().x() = std::numeric_limits<double>::infinity();
  expect(r, "NaN/inf");
  r = good;
  r.T_map_sensor.translation().y() = 1e39;
  expect(r, "float32 range");
  r = good;
  r.T_map_sensor.linear() *= 2.0;
  expect(r, "not a rotation");
  r = good;
  r.T_map_sensor.linear() = Eigen::Vector3d(1, 1, -1).asDiagonal();  // a reflection
  expect(r, "not a rotation");
  std::vector<std::uint8_t> small(91), big(93);
  CHECK_FALSE(EncodeKeyframeRecord(good, small).ok());
  CHECK_FALSE(EncodeKeyframeRecord(good, big).ok());
}

TEST_CASE("keyframe record: decoder rejects wrong sizes, corrupt fields and garbage") {
  Descriptor d{};
  d[10] = 0.6f;
  d[11] = 0.8f;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(-512.25, 33.5, 2.0);
  Record good{};
  REQUIRE(EncodeKeyframeRecord(MakeRecord(99, T, d), AsSpan(good)).ok());
  REQUIRE(DecodeKeyframeRecord(AsSpan(good)).ok());

  for (std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{91}, std::size_t{93}, std::size_t{184}}) {
    std::vector<std::uint8_t> buf(n, 0x5a);
    std::copy_n(good.begin(), std::min(n, good.size()), buf.begin());
    const auto r = DecodeKeyframeRecord(buf);
    CHECK_FALSE(r.ok());
    CHECK(r.status().code() == StatusCode::kDataLoss);
    CHECK(r.status().message().find("expected 92") != std::string::npos);
  }
  const auto expect = [](const Record& rec, const char* words) {
    const auto r = DecodeKeyframeRecord(AsSpan(rec));
    CHECK_FALSE(r.ok());
    CHECK(r.status().code() == StatusCode::kDataLoss);
    CHECK_MESSAGE(r.status().message().find(words) != std::string::npos, r.status().message());
  };
  Record bad{};
  expect(bad, "all-zero descriptor");  // all zeros: identity pose is fine, the descriptor is not
  bad.fill(0xff);
  expect(bad, "translation");
  bad = good;
  bad[21] |= 0x80;
  expect(bad, "reserved");
  bad = good;
  bad[4 + 3] = 0x7f, bad[4 + 2] = 0xc0;  // translation x = NaN
  expect(bad, "not finite");
  bad = good;
  for (int i = 22; i < 92; ++i) bad[i] &= 0x77;  // no code reaches 16383 any more
  expect(bad, "largest code");
  bad = good;
  {  // kept components (0.7, 0.7, 0.7): sum of squares 1.47 > 3/4
    std::uint64_t f = 0;
    const auto code = static_cast<std::uint64_t>(std::lround(0.7 * std::sqrt(2.0) * 16383));
    f |= code << 2 | code << 17 | code << 32;
    for (int i = 0; i < 6; ++i) bad[16 + i] = static_cast<std::uint8_t>(f >> (8 * i));
    expect(bad, "smallest-three");
  }
  bad = good;
  {  // code -16384 is never written
    std::uint64_t f = 0x4000ull << 2;
    for (int i = 0; i < 6; ++i) bad[16 + i] = static_cast<std::uint8_t>(f >> (8 * i));
    expect(bad, "never written");
  }
  bad = good;
  {  // kept (0.6, 0, 0) with the dropped one sqrt(1 - 0.36) = 0.8: fine; kept (0.45, 0.45, 0.45) vs 0.63:
     // fine; kept (0.65, 0.3, 0) vs dropped sqrt(1 - 0.5125) = 0.698: fine; kept (0.70, 0.1, 0.1) vs 0.70:
     // borderline fine. Kept (0.69, 0.4, 0.3) -> dropped 0.53 < 0.69: rejected.
    std::uint64_t f = 0;
    const auto c = [](double v) { return static_cast<std::uint64_t>(std::lround(v * std::sqrt(2.0) * 16383)); };
    f |= c(0.69) << 2 | c(0.4) << 17 | c(0.3) << 32;
    for (int i = 0; i < 6; ++i) bad[16 + i] = static_cast<std::uint8_t>(f >> (8 * i));
    expect(bad, "not the largest");
  }

  // Random garbage: never a crash; whatever is accepted is a well-formed record.
  std::mt19937 rng(77);
  int accepted = 0;
  constexpr int kTrials = 20000;
  Record junk{};
  for (int t = 0; t < kTrials; ++t) {
    for (auto& b : junk) b = static_cast<std::uint8_t>(rng());
    const auto r = DecodeKeyframeRecord(AsSpan(junk));
    if (!r.ok()) continue;
    ++accepted;
    double n2 = 0;
    for (float v : r->descriptor) {
      CHECK(std::isfinite(v));
      CHECK(v >= 0.0f);
      n2 += static_cast<double>(v) * static_cast<double>(v);
    }
    CHECK(std::fabs(n2 - 1.0) < 1e-5);
    CHECK(r->T_map_sensor.matrix().allFinite());
  }
  MESSAGE("random 92-byte garbage accepted: " << accepted << " / " << kTrials);
  CHECK(accepted < kTrials / 100);

  // Every single-bit flip of a good record: either rejected or decoded to a finite, unit record.
  for (std::size_t bit = 0; bit < 8 * good.size(); ++bit) {
    Record flipped = good;
    flipped[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    const auto r = DecodeKeyframeRecord(AsSpan(flipped));
    if (r.ok()) CHECK(r->T_map_sensor.matrix().allFinite());
  }
}

TEST_CASE("float16: exhaustive round trip and known values") {
  for (std::uint32_t h = 0; h <= 0xffff; ++h) {
    const float f = HalfToFloat(static_cast<std::uint16_t>(h));
    const bool is_nan = (h & 0x7c00) == 0x7c00 && (h & 0x3ff) != 0;
    if (is_nan) {
      if (!std::isnan(f)) FAIL("half NaN decoded to a number: " << h);
      if (!std::isnan(HalfToFloat(FloatToHalf(f)))) FAIL("NaN re-encoded to a number: " << h);
      continue;
    }
    if (FloatToHalf(f) != h) FAIL("half " << h << " -> " << f << " -> " << FloatToHalf(f));
  }
  CHECK(FloatToHalf(1.0f) == 0x3c00);
  CHECK(FloatToHalf(-2.0f) == 0xc000);
  CHECK(FloatToHalf(65504.0f) == 0x7bff);
  CHECK(FloatToHalf(65519.99f) == 0x7bff);
  CHECK(FloatToHalf(65520.0f) == 0x7c00);  // tie between 65504 (odd) and 2^16: to even = inf
  CHECK(FloatToHalf(0.1f) == 0x2e66);
  CHECK(FloatToHalf(std::ldexp(1.0f, -14)) == 0x0400);
  CHECK(FloatToHalf(std::ldexp(1.0f, -24)) == 0x0001);
  CHECK(FloatToHalf(std::ldexp(1.0f, -25)) == 0x0000);            // tie with 0: to even
  CHECK(FloatToHalf(std::ldexp(1.5f, -25)) == 0x0001);
  CHECK(FloatToHalf(std::ldexp(3.0f, -25)) == 0x0002);            // 1.5 x 2^-24: tie -> even 2
  CHECK(FloatToHalf(-0.0f) == 0x8000);
  CHECK(FloatToHalf(std::numeric_limits<float>::infinity()) == 0x7c00);
  CHECK(HalfToFloat(0x0001) == std::ldexp(1.0f, -24));
  CHECK(HalfToFloat(0x03ff) == std::ldexp(1023.0f, -24));
}

TEST_CASE("float16: rounding equals a brute-force nearest-half search (ties to even)") {
  // All finite non-negative halves in increasing order (bits 0x0000 .. 0x7bff are monotonic).
  std::vector<double> halves(0x7c00);
  for (std::uint32_t h = 0; h < 0x7c00; ++h) halves[h] = static_cast<double>(HalfToFloat(static_cast<std::uint16_t>(h)));
  const auto nearest = [&](double a) -> std::uint32_t {
    if (a >= 65520.0) return 0x7c00;
    const auto it = std::lower_bound(halves.begin(), halves.end(), a);
    const auto hi = static_cast<std::uint32_t>(it - halves.begin());
    if (hi == 0) return 0;
    if (hi == halves.size()) return 0x7bff;
    const std::uint32_t lo = hi - 1;
    const double dl = a - halves[lo], dh = halves[hi] - a;
    if (dl < dh) return lo;
    if (dh < dl) return hi;
    return (lo & 1) ? hi : lo;
  };
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> mant(1.0f, 2.0f);
  std::uniform_int_distribution<int> expo(-30, 17);
  for (int i = 0; i < 200000; ++i) {
    float f = std::ldexp(mant(rng), expo(rng));
    if (i % 3 == 0) {  // exact midpoints between neighbouring halves
      const std::uint32_t h = static_cast<std::uint32_t>(rng()) % 0x7bff;
      f = static_cast<float>(0.5 * (halves[h] + halves[h + 1]));
    }
    const std::uint32_t expect = nearest(static_cast<double>(f));
    const std::uint16_t got = FloatToHalf(f);
    if (got != expect) FAIL("float " << f << ": got " << got << ", expected " << expect);
    const std::uint16_t neg = FloatToHalf(-f);
    if (neg != (expect | 0x8000u)) FAIL("float " << -f << ": got " << neg);
  }
}

TEST_CASE("float16 arrays: sizes, non-finite values, little-endian layout") {
  const std::vector<float> v = {1.0f, -2.0f, 0.5f};
  std::vector<std::uint8_t> wire(6);
  REQUIRE(EncodeFloat16(v, wire).ok());
  CHECK(wire == std::vector<std::uint8_t>{0x00, 0x3c, 0x00, 0xc0, 0x00, 0x38});
  std::vector<float> back(3);
  REQUIRE(DecodeFloat16(wire, back).ok());
  CHECK(back == v);
  std::vector<std::uint8_t> short_wire(5);
  CHECK_FALSE(EncodeFloat16(v, short_wire).ok());
  CHECK_FALSE(DecodeFloat16(short_wire, back).ok());
  for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(), 70000.0f}) {
    const std::vector<float> b = {0.0f, bad};
    std::vector<std::uint8_t> w(4);
    const Status s = EncodeFloat16(b, w);
    CHECK_FALSE(s.ok());
    CHECK(s.message().find("value 1") != std::string::npos);
  }
  const std::vector<std::uint8_t> inf_wire = {0x00, 0x7c};
  std::vector<float> one(1);
  CHECK(DecodeFloat16(inf_wire, one).code() == StatusCode::kDataLoss);
}

}  // namespace
}  // namespace commerge
