// SPDX-License-Identifier: BSD-3-Clause
// Keyframe record codec (92 bytes) and float16 arrays: byte layout, round trips with derived error bounds,
// rejection of bad inputs and garbage, IEEE half rounding against a brute-force nearest-value search.
// Scan Context record (22 + 4 + N_r x N_s bytes): layout and shared pose header, round trip of cells and poses,
// the Scan Context distance after a round trip within its derived bound, encoder and decoder refusals.
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
#include "core/descriptor/scan_context.hpp"
#include "core/descriptor/solid.hpp"
#include "core/geometry/angles.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "tests/support/scan_context_scans.hpp"
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

namespace sc_record_test {  // unity builds compile this file with test_scan_context.cpp's helpers

constexpr int kRings = 20, kSectors = 60;
constexpr std::size_t kCells = static_cast<std::size_t>(kRings) * kSectors;
using ScRecord = std::vector<std::uint8_t>;

// Scan Context of a ray-cast street scan from (x, y) with heading yaw.
std::vector<float> StreetScanContext(float x_m, float y_m, float yaw_rad, std::uint32_t seed) {
  static const BoxScene scene = MakeStreetScene(11);
  return test::RayCastScanContext(scene, x_m, y_m, yaw_rad, seed);
}

ScRecord Encode(const KeyframePose& pose, const std::vector<float>& sc) {
  ScRecord rec(ScanContextRecordBytes(kRings, kSectors));
  const Status s = EncodeScanContextRecord(pose, sc, kRings, kSectors, rec);
  REQUIRE_MESSAGE(s.ok(), s.ToString());
  return rec;
}

std::vector<float> Decode(const ScRecord& rec, KeyframePose* pose = nullptr) {
  std::vector<float> out(kCells);
  const auto r = DecodeScanContextRecord(rec, kRings, kSectors, out);
  REQUIRE_MESSAGE(r.ok(), r.status().ToString());
  if (pose) *pose = *r;
  return out;
}

float Scale(const std::vector<float>& sc) { return *std::max_element(sc.begin(), sc.end()); }

// Derived bound of the Scan Context distance change (descriptor_codec.hpp): the largest angle by which a column
// of the query plus the largest by which a column of the candidate turned.
double MaxColumnAngle(const std::vector<float>& before, const std::vector<float>& after) {
  double worst = 0.0;
  for (int c = 0; c < kSectors; ++c) {
    double n2 = 0.0, e2 = 0.0;
    for (int r = 0; r < kRings; ++r) {
      const auto k = static_cast<std::size_t>(r * kSectors + c);
      const double v = static_cast<double>(before[k]), e = static_cast<double>(after[k]) - v;
      n2 += v * v;
      e2 += e * e;
    }
    if (n2 == 0.0) continue;
    const double ratio = std::sqrt(e2 / n2);
    worst = std::max(worst, ratio < 1.0 ? std::asin(ratio) : kPi);
  }
  return worst;
}

TEST_CASE("Scan Context record: size, byte layout and the pose header shared with the keyframe record") {
  CHECK(ScanContextRecordBytes(20, 60) == 1226);
  CHECK(ScanContextRecordBytes(1, 1) == 27);
  std::vector<float> sc(kCells, 0.0f);
  sc[0] = 4.0f;                // ring 0, sector 0: the scale
  sc[1] = 2.0f;                // round(127.5) = 128
  sc[kSectors + 5] = 1e-3f;    // tiny: lifted to code 1
  sc[kCells - 1] = -0.3f;      // negative: code 1
  KeyframePose pose;
  pose.keyframe_index = 0x01020304u;
  pose.T_map_sensor.translation() = Eigen::Vector3d(1.0, -2.0, 0.5);
  pose.T_map_sensor.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const ScRecord rec = Encode(pose, sc);
  // The first 22 bytes are the keyframe record's pose header, byte for byte.
  Descriptor d{};
  d[0] = 1.0f;
  Record solid{};
  REQUIRE(EncodeKeyframeRecord(MakeRecord(pose.keyframe_index, pose.T_map_sensor, d), AsSpan(solid)).ok());
  CHECK(std::equal(rec.begin(), rec.begin() + 22, solid.begin()));
  // 4.0f = 0x40800000, little-endian.
  CHECK(rec[22] == 0x00);
  CHECK(rec[23] == 0x00);
  CHECK(rec[24] == 0x80);
  CHECK(rec[25] == 0x40);
  CHECK(rec[26] == 255);
  CHECK(rec[27] == 128);
  CHECK(rec[26 + kSectors + 5] == 1);
  CHECK(rec[rec.size() - 1] == 1);
  std::size_t nonzero = 0;
  for (std::size_t i = 26; i < rec.size(); ++i) nonzero += rec[i] != 0;
  CHECK(nonzero == 4);
  KeyframePose back;
  const std::vector<float> out = Decode(rec, &back);
  CHECK(back.keyframe_index == pose.keyframe_index);
  CHECK(out[0] == 4.0f);
  CHECK(out[1] == doctest::Approx(128.0 * 4.0 / 255.0));
  CHECK(out[kCells - 1] == doctest::Approx(4.0 / 255.0));  // the sign of a negative cell is lost (documented)
}

TEST_CASE("Scan Context record round trip: cells within scale / 510, empty stays empty, poses as the keyframe record") {
  std::mt19937 rng(31);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  double max_t_err = 0.0, max_rot_err = 0.0, max_cell_ratio = 0.0;
  int scans = 0;
  for (int k = 0; k < 40; ++k) {
    std::vector<float> sc;
    if (k < 20) {
      sc = StreetScanContext(-80.0f + 8.0f * static_cast<float>(k), 0.3f, 0.1f * static_cast<float>(k), 40u + k);
    } else {  // random grids: a wide range of values, tiny cells, empty columns
      sc.assign(kCells, 0.0f);
      for (float& v : sc) v = u(rng) < 0.4f ? 0.0f : std::pow(10.0f, -4.0f + 6.0f * u(rng));
    }
    ++scans;
    KeyframePose pose;
    pose.keyframe_index = static_cast<std::uint32_t>(rng());
    pose.T_map_sensor = RandomPose(rng, 10000.0);
    KeyframePose back;
    const std::vector<float> out = Decode(Encode(pose, sc), &back);
    CHECK(back.keyframe_index == pose.keyframe_index);
    max_t_err = std::max(max_t_err, (back.T_map_sensor.translation() - pose.T_map_sensor.translation()).cwiseAbs().maxCoeff());
    max_rot_err = std::max(max_rot_err, RotationErrorRad(back.T_map_sensor.linear(), pose.T_map_sensor.linear()));
    const double scale = static_cast<double>(Scale(sc));
    for (std::size_t i = 0; i < kCells; ++i) {
      const double v = static_cast<double>(sc[i]), o = static_cast<double>(out[i]);
      if (v == 0.0) {
        REQUIRE(o == 0.0);
        continue;
      }
      REQUIRE(o > 0.0);  // non-empty stays non-empty
      const double err = std::fabs(o - v);
      if (v >= scale / 510.0) {
        // Half a code step, plus the float rounding of the decoded value.
        REQUIRE(err <= scale / 510.0 * (1.0 + 1e-6));
        max_cell_ratio = std::max(max_cell_ratio, err / (scale / 510.0));
      } else {
        REQUIRE(o == doctest::Approx(scale / 255.0));  // lifted to code 1
      }
    }
  }
  MESSAGE("Scan Context record round trip over " << scans << " grids: max cell error / (scale / 510) "
                                                 << max_cell_ratio << ", translation " << max_t_err * 1e3
                                                 << " mm at 10 km, rotation " << max_rot_err << " rad");
  CHECK(max_t_err <= 4.9e-4);  // the keyframe record's bounds
  CHECK(max_rot_err < 2e-4);
}

TEST_CASE("Scan Context record: the distance after a round trip stays within its derived bound") {
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> yaw(-3.14159f, 3.14159f);
  std::vector<std::vector<float>> in, out;
  for (int k = 0; k < 24; ++k) {
    // Consecutive scans 3 m apart (near pairs) and further ones, turned at random.
    in.push_back(StreetScanContext(-70.0f + 3.0f * static_cast<float>(k), 0.5f, yaw(rng), 70u + k));
    out.push_back(Decode(Encode(KeyframePose{}, in.back())));
  }
  double max_dd = 0.0, sum_dd = 0.0, max_ratio = 0.0, max_near_dd = 0.0;
  int pairs = 0;
  for (std::size_t a = 0; a < in.size(); ++a) {
    for (std::size_t b = 0; b < in.size(); ++b) {
      const double d = MatchScanContext(in[a], in[b], kRings, kSectors).distance;
      const double dq = MatchScanContext(out[a], out[b], kRings, kSectors).distance;
      const double bound = MaxColumnAngle(in[a], out[a]) + MaxColumnAngle(in[b], out[b]) + 1e-9;
      const double dd = std::fabs(dq - d);
      CHECK(dd <= bound);
      max_ratio = std::max(max_ratio, dd / bound);
      max_dd = std::max(max_dd, dd);
      if (d < 0.3) max_near_dd = std::max(max_near_dd, dd);
      sum_dd += dd;
      ++pairs;
    }
  }
  MESSAGE("Scan Context record: " << pairs << " pairs, max |dD| " << max_dd << " (pairs below 0.3: " << max_near_dd
                                  << "), mean " << sum_dd / pairs << ", max |dD| / derived bound " << max_ratio);
  CHECK(max_dd < 3e-3);  // measured 2.1e-3 (descriptor_codec.hpp)
}

TEST_CASE("Scan Context record: encoder refusals") {
  std::vector<float> sc(kCells, 0.0f);
  sc[7] = 3.0f;
  ScRecord rec(ScanContextRecordBytes(kRings, kSectors));
  REQUIRE(EncodeScanContextRecord(KeyframePose{}, sc, kRings, kSectors, rec).ok());
  const auto expect = [&](const KeyframePose& pose, const std::vector<float>& d, int rings, int sectors,
                          std::size_t out_size, const char* words) {
    ScRecord out(out_size);
    const Status s = EncodeScanContextRecord(pose, d, rings, sectors, out);
    CHECK_FALSE(s.ok());
    CHECK(s.code() == StatusCode::kInvalidArgument);
    CHECK_MESSAGE(s.message().find(words) != std::string::npos, s.message());
  };
  const std::size_t size = rec.size();
  expect(KeyframePose{}, sc, kRings, kSectors, size - 1, "expected 1226");
  expect(KeyframePose{}, sc, kRings, kSectors, size + 1, "expected 1226");
  expect(KeyframePose{}, sc, 21, kSectors, ScanContextRecordBytes(21, kSectors), "holds 1200 values");
  expect(KeyframePose{}, sc, kRings, 7, size, "grid 20 x 7");
  std::vector<float> bad = sc;
  bad[3] = std::numeric_limits<float>::quiet_NaN();
  expect(KeyframePose{}, bad, kRings, kSectors, size, "value 3");
  bad = sc;
  bad[kCells - 1] = -std::numeric_limits<float>::infinity();
  expect(KeyframePose{}, bad, kRings, kSectors, size, "finite");
  expect(KeyframePose{}, std::vector<float>(kCells, 0.0f), kRings, kSectors, size, "all zero");
  bad.assign(kCells, 0.0f);
  bad[9] = -0.5f;
  expect(KeyframePose{}, bad, kRings, kSectors, size, "no positive cell");
  KeyframePose pose;
  pose.T_map_sensor.translation().x() = std::numeric_limits<double>::quiet_NaN();
  expect(pose, sc, kRings, kSectors, size, "NaN/inf");
  pose = KeyframePose{};
  pose.T_map_sensor.translation().z() = 1e39;
  expect(pose, sc, kRings, kSectors, size, "float32 range");
  pose = KeyframePose{};
  pose.T_map_sensor.linear() = Eigen::Vector3d(1, -1, 1).asDiagonal();  // a reflection
  expect(pose, sc, kRings, kSectors, size, "not a rotation");
}

TEST_CASE("Scan Context record: decoder refusals (size, pose fields, scale, codes, grid)") {
  std::vector<float> sc(kCells, 0.0f);
  sc[100] = 6.0f;
  sc[101] = 1.5f;
  KeyframePose pose;
  pose.keyframe_index = 42;
  pose.T_map_sensor.translation() = Eigen::Vector3d(5.0, 6.0, 7.0);
  pose.T_map_sensor.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const ScRecord good = Encode(pose, sc);
  std::vector<float> out(kCells);
  REQUIRE(DecodeScanContextRecord(good, kRings, kSectors, out).ok());

  const auto expect = [&](const ScRecord& rec, const char* words) {
    const auto r = DecodeScanContextRecord(rec, kRings, kSectors, out);
    CHECK_FALSE(r.ok());
    CHECK(r.status().code() == StatusCode::kDataLoss);
    CHECK_MESSAGE(r.status().message().find(words) != std::string::npos, r.status().message());
  };
  for (const std::size_t n : {std::size_t{0}, std::size_t{22}, good.size() - 1, good.size() + 1}) {
    ScRecord buf(n, 0x5a);
    std::copy_n(good.begin(), std::min(n, good.size()), buf.begin());
    expect(buf, "expected 1226");
  }
  ScRecord bad = good;
  bad[21] |= 0x80;  // reserved rotation bit
  expect(bad, "reserved");
  bad = good;
  bad[4 + 3] = 0x7f, bad[4 + 2] = 0xc0;  // translation x = NaN
  expect(bad, "not finite");
  bad = good;
  {  // kept components (0.7, 0.7, 0.7): no smallest-three quaternion
    const auto code = static_cast<std::uint64_t>(std::lround(0.7 * std::sqrt(2.0) * 16383));
    const std::uint64_t f = code << 2 | code << 17 | code << 32;
    for (int i = 0; i < 6; ++i) bad[16 + i] = static_cast<std::uint8_t>(f >> (8 * i));
    expect(bad, "smallest-three");
  }
  const auto with_scale = [&](float scale) {
    ScRecord r = good;
    std::uint32_t u = 0;
    std::memcpy(&u, &scale, 4);
    for (int i = 0; i < 4; ++i) r[22 + i] = static_cast<std::uint8_t>(u >> (8 * i));
    return r;
  };
  expect(with_scale(0.0f), "scale");
  expect(with_scale(-1.0f), "scale");
  expect(with_scale(std::numeric_limits<float>::quiet_NaN()), "scale");
  expect(with_scale(std::numeric_limits<float>::infinity()), "scale");
  CHECK(DecodeScanContextRecord(with_scale(2.0f), kRings, kSectors, out).ok());  // any finite positive scale
  bad = good;
  std::fill(bad.begin() + 26, bad.end(), std::uint8_t{0});
  expect(bad, "no non-zero code");
  bad = good;
  for (std::size_t i = 26; i < bad.size(); ++i) bad[i] &= 0x7f;  // no code reaches 255
  expect(bad, "largest code");
  // The grid is the caller's: another grid of the same cell count decodes, another count does not fit.
  std::vector<float> out_30(kCells);
  CHECK(DecodeScanContextRecord(good, 40, 30, out_30).ok());
  const auto other = DecodeScanContextRecord(good, 19, kSectors, Span<float>(out.data(), 19 * kSectors));
  CHECK(other.status().code() == StatusCode::kDataLoss);
  CHECK(DecodeScanContextRecord(good, kRings, 7, out).status().code() == StatusCode::kInvalidArgument);
  CHECK(DecodeScanContextRecord(good, kRings, kSectors, Span<float>(out.data(), kCells - 1)).status().code() ==
        StatusCode::kInvalidArgument);

  // Random garbage of the right size: never a crash; whatever is accepted is finite and non-negative.
  std::mt19937 rng(77);
  ScRecord junk(good.size());
  int accepted = 0;
  for (int t = 0; t < 2000; ++t) {
    for (auto& b : junk) b = static_cast<std::uint8_t>(rng());
    const auto r = DecodeScanContextRecord(junk, kRings, kSectors, out);
    if (!r.ok()) continue;
    ++accepted;
    CHECK(r->T_map_sensor.matrix().allFinite());
    for (const float v : out) CHECK((std::isfinite(v) && v >= 0.0f));
  }
  MESSAGE("random 1226-byte garbage accepted: " << accepted << " / 2000");
}

}  // namespace sc_record_test

}  // namespace
}  // namespace commerge
