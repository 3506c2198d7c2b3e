// SPDX-License-Identifier: BSD-3-Clause
// platform/lcm/input_codec: lidar_scan_t and odometry_t (the live input of `commerge robot`) to and from LCM wire
// bytes. Expectations come from the generated LCM types (their own encode of a struct filled by hand, and
// fingerprints) and from fields read at hand-computed big-endian offsets; hostile buffers (foreign types, every
// truncation, trailing bytes, num_points and string lengths patched beyond MAX or the buffer, non-finite and
// non-unit values) are refused with DataLoss naming what is wrong, except non-finite points, which are dropped
// and counted. Last, both messages travel through LcmBus (memq://) into ScanOdometrySync.
#include <doctest/doctest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <commerge/lidar_scan_t.hpp>
#include <commerge/odometry_t.hpp>
#include <commerge/robot_status_t.hpp>

#include "core/common/float_limits.hpp"
#include "core/agent/live_input.hpp"
#include "core/agent/messages.hpp"
#include "core/agent/scan_odometry_sync.hpp"
#include "platform/lcm/input_codec.hpp"
#include "platform/lcm/lcm_bus.hpp"
#include "platform/lcm/message_codec.hpp"
#include "tests/platform/lcm/lcm_test_util.hpp"

namespace commerge::platform {
namespace {

const double kNaNd = std::numeric_limits<double>::quiet_NaN();
const double kInfd = std::numeric_limits<double>::infinity();

bool SameBits(float a, float b) { return std::memcmp(&a, &b, sizeof(float)) == 0; }

// ---- lidar_scan_t ----

LidarScan MakeScan(std::size_t n) {
  LidarScan m;
  m.utime_us = 1763800000123456;
  m.frame = "velodyne";
  m.points.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const float f = static_cast<float>(i);
    m.points[i] = {0.25f * f - 3.0f, -0.5f * f, 1.75f + 0.125f * f, 0.01f * f};
  }
  if (n >= 4) {  // float corner values survive bit for bit
    m.points[1] = {-0.0f, 1e-40f, std::numeric_limits<float>::max(), -1.0f};
    m.points[2] = {std::numeric_limits<float>::lowest(), std::numeric_limits<float>::min(), 123456.789f, kFloatNaN};
  }
  return m;
}

commerge::lidar_scan_t ToLcm(const LidarScan& m) {
  commerge::lidar_scan_t msg{};
  msg.utime = m.utime_us;
  msg.frame = m.frame;
  msg.num_points = static_cast<std::int32_t>(m.points.size());
  for (const PointXYZI& p : m.points) {
    msg.x.push_back(p.x);
    msg.y.push_back(p.y);
    msg.z.push_back(p.z);
    msg.intensity.push_back(p.intensity);
  }
  return msg;
}

Buffer Encoded(const LidarScan& m) {
  Buffer b;
  REQUIRE(EncodeLidarScan(m, &b).ok());
  return b;
}

// Bit for bit; one assertion for the whole scan (up to 262144 points), naming the first point that differs.
void CheckSamePoints(const std::vector<PointXYZI>& got, const std::vector<PointXYZI>& want) {
  REQUIRE(got.size() == want.size());
  std::size_t differ = 0, first = want.size();
  for (std::size_t i = 0; i < want.size(); ++i) {
    if (!SameBits(got[i].x, want[i].x) || !SameBits(got[i].y, want[i].y) || !SameBits(got[i].z, want[i].z) ||
        !SameBits(got[i].intensity, want[i].intensity)) {
      if (differ++ == 0) first = i;
    }
  }
  INFO(differ, " of ", want.size(), " points differ, the first at index ", first);
  CHECK(differ == 0);
}

// Offsets for frame "velodyne" (8 bytes): fingerprint 8, utime 8, frame length 4 + 9, then num_points.
constexpr std::size_t kScanFrameLength = 16;
constexpr std::size_t kScanNumPoints = 16 + 4 + 9;  // 29
std::size_t ScanX(std::size_t i) { return kScanNumPoints + 4 + 4 * i; }

// ---- odometry_t ----

OdometrySample MakeOdometry() {
  OdometrySample m;
  m.utime_us = 1763800000654321;
  m.odom_frame = "odom";
  m.sensor_frame = "velodyne";
  m.T_odom_sensor = Eigen::Isometry3d::Identity();
  m.T_odom_sensor.linear() =
      Eigen::AngleAxisd(2.4, Eigen::Vector3d(0.3, -1.0, 0.2).normalized()).toRotationMatrix();
  m.T_odom_sensor.translation() = Eigen::Vector3d(1234.5678, -87.125, 3.0e-3);
  for (std::size_t i = 0; i < 36; ++i) m.covariance[i] = (i % 7 == 0) ? 0.01 * static_cast<double>(i + 1) : -1e-6 * static_cast<double>(i);
  return m;
}

commerge::odometry_t ToLcm(const OdometrySample& m) {
  commerge::odometry_t msg{};
  msg.utime = m.utime_us;
  msg.odom_frame = m.odom_frame;
  msg.sensor_frame = m.sensor_frame;
  const Eigen::Quaterniond q = Eigen::Quaterniond(m.T_odom_sensor.linear()).normalized();
  for (int i = 0; i < 3; ++i) msg.position[i] = m.T_odom_sensor.translation()[i];
  msg.orientation[0] = q.w();
  msg.orientation[1] = q.x();
  msg.orientation[2] = q.y();
  msg.orientation[3] = q.z();
  for (std::size_t i = 0; i < 36; ++i) msg.covariance[i / 6][i % 6] = m.covariance[i];
  return msg;
}

Buffer Encoded(const OdometrySample& m) {
  Buffer b;
  REQUIRE(EncodeOdometry(m, &b).ok());
  return b;
}

// Offsets for "odom" (4) and "velodyne" (8): fingerprint 8, utime 8, 4 + 5, 4 + 9, then the doubles.
constexpr std::size_t kOdomFrameLength = 16;
constexpr std::size_t kSensorFrameLength = 16 + 4 + 5;           // 25
constexpr std::size_t kPosition = kSensorFrameLength + 4 + 9;    // 38
constexpr std::size_t kOrientation = kPosition + 24;             // 62
constexpr std::size_t kCovariance = kOrientation + 32;           // 94
constexpr std::size_t kOdometryBytes = kCovariance + 36 * 8;     // 382

// =====================================================================================================

TEST_CASE("input codec: channel names are the documented ones") {
  CHECK(std::string(kLidarScanChannel) == "COMMERGE_LIDAR_SCAN");
  CHECK(std::string(kOdometryChannel) == "COMMERGE_ODOMETRY");
  // Stays on the board, with a receive buffer for whole scans.
  CHECK(std::string(kDefaultInputLcmUrl) == "udpm://239.255.76.67:7668?ttl=0&recv_buf_size=16777216");
  CHECK(commerge::lidar_scan_t::MAX_POINTS == 262144);
  CHECK(kMaxLidarScanPoints == 128u * 2048u);
}

// ---- lidar_scan_t ----

TEST_CASE("input codec: lidar scan round trip keeps the time, the frame and every finite point bit for bit") {
  LidarScan m = MakeScan(100);
  m.points[2].intensity = 0.5f;  // keep this one NaN-free: NaN handling has its own test
  auto d = DecodeLidarScan(S(Encoded(m)));
  REQUIRE(d.ok());
  CHECK(d->utime_us == m.utime_us);
  CHECK(d->frame == m.frame);
  CHECK(d->dropped_nonfinite == 0);
  CheckSamePoints(d->points, m.points);

  LidarScan empty;  // no points, empty frame name
  const Buffer e = Encoded(empty);
  CHECK(e.size() == 8 + 8 + 4 + 1 + 4);
  auto de = DecodeLidarScan(S(e));
  REQUIRE(de.ok());
  CHECK(de->utime_us == 0);
  CHECK(de->frame.empty());
  CHECK(de->points.empty());
}

TEST_CASE("input codec: lidar scan bytes are the generated type's, parallel arrays at hand-computed offsets") {
  const LidarScan m = MakeScan(6);
  const Buffer b = Encoded(m);
  CHECK(b == LcmEncode(ToLcm(m)));
  REQUIRE(b.size() == kScanNumPoints + 4 + 16 * 6);
  CHECK(GetBe(b, 0, 8) == commerge::lidar_scan_t::getHash());
  CHECK(GetBe(b, 8, 8) == 1763800000123456);
  CHECK(GetBe(b, kScanFrameLength, 4) == 9);
  CHECK(std::memcmp(b.data() + 20, "velodyne", 9) == 0);  // with its NUL
  CHECK(GetBe(b, kScanNumPoints, 4) == 6);
  CHECK(SameBits(GetBeFloat(b, ScanX(0)), m.points[0].x));
  CHECK(SameBits(GetBeFloat(b, ScanX(5)), m.points[5].x));
  CHECK(SameBits(GetBeFloat(b, ScanX(6) + 4 * 3), m.points[3].y));   // y[3]
  CHECK(SameBits(GetBeFloat(b, ScanX(12) + 4 * 1), m.points[1].z));  // z[1] = FLT_MAX
  CHECK(SameBits(GetBeFloat(b, ScanX(18) + 4 * 4), m.points[4].intensity));
  CHECK(std::isnan(GetBeFloat(b, ScanX(18) + 4 * 2)));  // intensity[2] is NaN on the wire too
}

TEST_CASE("input codec: a lidar scan of exactly MAX_POINTS round-trips, the encoder refuses more and long names") {
  LidarScan m = MakeScan(kMaxLidarScanPoints);
  m.points[2].intensity = 1.0f;
  m.frame = std::string(kMaxFrameNameBytes, 'f');  // the longest name
  const Buffer b = Encoded(m);
  CHECK(b.size() == 8 + 8 + 4 + 257 + 4 + 16 * kMaxLidarScanPoints);
  auto d = DecodeLidarScan(S(b));
  REQUIRE(d.ok());
  CHECK(d->frame == m.frame);
  CheckSamePoints(d->points, m.points);

  Buffer untouched = {1, 2, 3};
  m.points.push_back({});
  CheckInvalid(EncodeLidarScan(m, &untouched), {"lidar_scan_t", "points", "262145", "at most 262144"});
  CHECK(untouched == Buffer{1, 2, 3});  // left as it was
  LidarScan named = MakeScan(2);
  named.frame = std::string(kMaxFrameNameBytes + 1, 'f');
  CheckInvalid(EncodeLidarScan(named, &untouched), {"lidar_scan_t", "frame", "257"});
  named.frame = std::string("velo\0dyne", 9);
  CheckInvalid(EncodeLidarScan(named, &untouched), {"frame", "NUL"});
}

TEST_CASE("input codec: non-finite points are dropped and counted, the scan is kept") {
  LidarScan m = MakeScan(10);
  m.points[2].intensity = 0.5f;
  std::vector<PointXYZI> finite;
  for (std::size_t i = 0; i < m.points.size(); ++i) {
    if (i == 3) m.points[i].x = kFloatNaN;
    if (i == 5) m.points[i].y = kFloatInf;
    if (i == 6) m.points[i].z = -kFloatInf;
    if (i == 8) m.points[i].intensity = kFloatNaN;  // intensity is not a coordinate: kept
    if (i != 3 && i != 5 && i != 6) finite.push_back(m.points[i]);
  }
  auto d = DecodeLidarScan(S(Encoded(m)));
  REQUIRE(d.ok());
  CHECK(d->dropped_nonfinite == 3);
  CheckSamePoints(d->points, finite);
  CHECK(std::isnan(d->points[d->points.size() - 2].intensity));  // point 8

  // Every point NaN: an empty scan, still a scan.
  LidarScan all = MakeScan(5);
  for (PointXYZI& p : all.points) p = {kFloatNaN, kFloatNaN, kFloatNaN, 0.0f};
  auto da = DecodeLidarScan(S(Encoded(all)));
  REQUIRE(da.ok());
  CHECK(da->points.empty());
  CHECK(da->dropped_nonfinite == 5);
}

TEST_CASE("input codec: LidarScanDecoder reuses its buffers and never keeps points of an earlier scan") {
  LidarScanDecoder decoder;
  LidarScan out;
  LidarScan big = MakeScan(5000), small = MakeScan(7), none = MakeScan(0);
  big.points[2].intensity = small.points[2].intensity = 0.0f;
  REQUIRE(decoder.Decode(S(Encoded(big)), &out).ok());
  CheckSamePoints(out.points, big.points);
  const PointXYZI* buffer = out.points.data();
  REQUIRE(decoder.Decode(S(Encoded(small)), &out).ok());
  CheckSamePoints(out.points, small.points);
  CHECK(out.points.data() == buffer);  // the capacity was reused
  REQUIRE(decoder.Decode(S(Encoded(none)), &out).ok());
  CHECK(out.points.empty());  // the generated decoder leaves the arrays of `small`: none of them may show
  CHECK(out.dropped_nonfinite == 0);
  REQUIRE(decoder.Decode(S(Encoded(small)), &out).ok());
  Buffer cut = Encoded(small);
  cut.pop_back();
  CHECK(decoder.Decode(S(cut), &out).code() == StatusCode::kDataLoss);
  CHECK(out.points.empty());  // an error leaves no points behind
}

TEST_CASE("input codec: a lidar scan num_points patched beyond MAX or the buffer is refused before allocating") {
  LidarScan m = MakeScan(6);
  m.points[2].intensity = 0.0f;
  const Buffer b = Encoded(m);
  CheckPatchedCount(b, kScanNumPoints, 4, 6, static_cast<std::int64_t>(kMaxLidarScanPoints), "num_points",
                    DecodeLidarScan);
  // A decoder that trusted the count would allocate four arrays of up to 2^31 floats; a bounded one answers in
  // microseconds. 100 ms leaves room for emulation and a loaded machine.
  using Clock = std::chrono::steady_clock;
  for (std::uint32_t v : {0x7fffffffu, 0x80000000u, 0xffffffffu, 262144u, 7u}) {
    INFO("num_points patched to ", v);
    Buffer p = b;
    PutBe32(&p, kScanNumPoints, v);
    const auto start = Clock::now();
    const auto r = DecodeLidarScan(S(p));
    CHECK(std::chrono::duration<double>(Clock::now() - start).count() < 0.1);
    CheckDataLoss(r, {"lidar_scan_t", "num_points"});
  }
  // One point fewer than the arrays hold: the counts disagree with the buffer.
  Buffer fewer = b;
  PutBe32(&fewer, kScanNumPoints, 5);
  CheckDataLoss(DecodeLidarScan(S(fewer)), {"lidar_scan_t", "trailing"});
}

TEST_CASE("input codec: lidar scan frame lengths patched beyond 257 or the buffer are refused") {
  LidarScan m = MakeScan(3);
  m.points[2].intensity = 0.0f;
  CheckPatchedStringLength(Encoded(m), kScanFrameLength, "velodyne", "frame", DecodeLidarScan);
  m.frame.clear();
  CheckPatchedStringLength(Encoded(m), kScanFrameLength, "", "frame", DecodeLidarScan);
}

// ---- odometry_t ----

TEST_CASE("input codec: odometry round trip keeps the frames, the pose and the covariance") {
  const OdometrySample m = MakeOdometry();
  auto d = DecodeOdometry(S(Encoded(m)));
  REQUIRE(d.ok());
  CHECK(d->utime_us == m.utime_us);
  CHECK(d->odom_frame == "odom");
  CHECK(d->sensor_frame == "velodyne");
  CHECK((d->T_odom_sensor.translation() - m.T_odom_sensor.translation()).norm() == 0.0);  // doubles: exact
  CHECK(RotationErrorRad(d->T_odom_sensor.linear(), m.T_odom_sensor.linear()) < 1e-12);
  CHECK(d->covariance == m.covariance);

  OdometrySample identity;  // empty names, unknown covariance
  const Buffer e = Encoded(identity);
  CHECK(e.size() == 8 + 8 + 5 + 5 + 8 * 43);
  auto de = DecodeOdometry(S(e));
  REQUIRE(de.ok());
  CHECK(de->odom_frame.empty());
  CHECK(de->T_odom_sensor.isApprox(Eigen::Isometry3d::Identity(), 0.0));
  CHECK(de->covariance == std::array<double, 36>{});
}

TEST_CASE("input codec: odometry bytes are the generated type's, fields at hand-computed offsets") {
  const OdometrySample m = MakeOdometry();
  const Buffer b = Encoded(m);
  CHECK(b == LcmEncode(ToLcm(m)));
  REQUIRE(b.size() == kOdometryBytes);
  CHECK(GetBe(b, 0, 8) == commerge::odometry_t::getHash());
  CHECK(GetBe(b, 8, 8) == 1763800000654321);
  CHECK(GetBe(b, kOdomFrameLength, 4) == 5);
  CHECK(GetBe(b, kSensorFrameLength, 4) == 9);
  CHECK(GetBeDouble(b, kPosition) == 1234.5678);
  CHECK(GetBeDouble(b, kPosition + 16) == 3.0e-3);
  const Eigen::Quaterniond q(m.T_odom_sensor.linear());
  CHECK(std::abs(GetBeDouble(b, kOrientation)) == doctest::Approx(std::abs(q.w())).epsilon(1e-15));
  double norm2 = 0.0;
  for (int i = 0; i < 4; ++i) norm2 += GetBeDouble(b, kOrientation + 8 * static_cast<std::size_t>(i)) *
                                       GetBeDouble(b, kOrientation + 8 * static_cast<std::size_t>(i));
  CHECK(norm2 == doctest::Approx(1.0).epsilon(1e-15));
  CHECK(GetBeDouble(b, kCovariance) == m.covariance[0]);
  CHECK(GetBeDouble(b, kCovariance + 8 * 14) == m.covariance[14]);  // row 2, column 2
  CHECK(GetBeDouble(b, kCovariance + 8 * 35) == m.covariance[35]);
}

TEST_CASE("input codec: the odometry decoder refuses non-finite values and a quaternion that is not unit") {
  const Buffer valid = Encoded(MakeOdometry());
  for (std::size_t i = 0; i < 3; ++i) {
    for (double bad : {kNaNd, kInfd, -kInfd}) {
      Buffer b = valid;
      PutBeDouble(&b, kPosition + 8 * i, bad);
      CheckDataLoss(DecodeOdometry(S(b)), {"odometry_t", "position", "not finite"});
    }
  }
  for (std::size_t i = 0; i < 4; ++i) {
    Buffer b = valid;
    PutBeDouble(&b, kOrientation + 8 * i, kNaNd);
    CheckDataLoss(DecodeOdometry(S(b)), {"odometry_t", "orientation", "not finite"});
  }
  // w, x, y, z scaled: beyond 1 +- 1e-3 refused, within it accepted and renormalised.
  auto scaled = [&](double s) {
    Buffer b = valid;
    for (std::size_t i = 0; i < 4; ++i) PutBeDouble(&b, kOrientation + 8 * i, s * GetBeDouble(valid, kOrientation + 8 * i));
    return b;
  };
  CheckDataLoss(DecodeOdometry(S(scaled(1.002))), {"odometry_t", "orientation", "norm", "unit"});
  CheckDataLoss(DecodeOdometry(S(scaled(0.998))), {"odometry_t", "orientation", "norm"});
  CheckDataLoss(DecodeOdometry(S(scaled(0.0))), {"odometry_t", "orientation", "norm"});
  auto near = DecodeOdometry(S(scaled(1.0009)));
  REQUIRE(near.ok());
  CHECK(RotationErrorRad(near->T_odom_sensor.linear(), MakeOdometry().T_odom_sensor.linear()) < 1e-12);
  CHECK((near->T_odom_sensor.linear().transpose() * near->T_odom_sensor.linear() - Eigen::Matrix3d::Identity())
            .cwiseAbs()
            .maxCoeff() < 1e-14);
  Buffer cov = valid;
  PutBeDouble(&cov, kCovariance + 8 * 17, kNaNd);
  CheckDataLoss(DecodeOdometry(S(cov)), {"odometry_t", "covariance[17]", "not finite"});
}

TEST_CASE("input codec: the odometry encoder refuses what the message cannot say, naming the field") {
  Buffer untouched = {9};
  OdometrySample m = MakeOdometry();
  m.T_odom_sensor.translation().x() = kNaNd;
  CheckInvalid(EncodeOdometry(m, &untouched), {"odometry_t", "T_odom_sensor"});
  m = MakeOdometry();
  m.T_odom_sensor.linear()(0, 1) += 0.01;  // not a rotation
  CheckInvalid(EncodeOdometry(m, &untouched), {"odometry_t", "T_odom_sensor", "orthonormal"});
  m = MakeOdometry();
  m.covariance[35] = kInfd;
  CheckInvalid(EncodeOdometry(m, &untouched), {"odometry_t", "covariance[35]"});
  m = MakeOdometry();
  m.odom_frame = std::string(kMaxFrameNameBytes + 1, 'o');
  CheckInvalid(EncodeOdometry(m, &untouched), {"odometry_t", "odom_frame"});
  m = MakeOdometry();
  m.sensor_frame = std::string("a\0b", 3);
  CheckInvalid(EncodeOdometry(m, &untouched), {"odometry_t", "sensor_frame", "NUL"});
  CHECK(untouched == Buffer{9});
  m = MakeOdometry();
  m.odom_frame = std::string(kMaxFrameNameBytes, 'o');
  m.sensor_frame = std::string(kMaxFrameNameBytes, 's');
  auto d = DecodeOdometry(S(Encoded(m)));
  REQUIRE(d.ok());
  CHECK(d->sensor_frame == m.sensor_frame);
}

TEST_CASE("input codec: odometry frame lengths patched beyond 257 or the buffer are refused") {
  const Buffer b = Encoded(MakeOdometry());
  CheckPatchedStringLength(b, kOdomFrameLength, "odom", "odom_frame", DecodeOdometry);
  CheckPatchedStringLength(b, kSensorFrameLength, "velodyne", "sensor_frame", DecodeOdometry);
}

// ---- both ----

TEST_CASE("input codec: every truncation of a valid buffer is refused, and trailing bytes") {
  LidarScan scan = MakeScan(5);
  scan.points[2].intensity = 0.0f;
  CheckEveryTruncationRefused(Encoded(scan), DecodeLidarScan, "lidar_scan_t");
  CheckEveryTruncationRefused(Encoded(MakeOdometry()), DecodeOdometry, "odometry_t");
  CheckTrailingBytesRefused(Encoded(scan), DecodeLidarScan, "lidar_scan_t");
  CheckTrailingBytesRefused(Encoded(MakeOdometry()), DecodeOdometry, "odometry_t");
}

TEST_CASE("input codec: every decoder refuses a foreign message type by its fingerprint") {
  LidarScan scan = MakeScan(5);
  scan.points[2].intensity = 0.0f;
  const Buffer s = Encoded(scan), o = Encoded(MakeOdometry());
  commerge::robot_status_t status{};
  const Buffer r = LcmEncode(status);
  Buffer batch_bytes;
  REQUIRE(EncodeKeyframeBatch(KeyframeBatch{}, &batch_bytes).ok());
  const Buffer batch = batch_bytes;
  for (const Buffer* foreign : {&o, &r, &batch}) CheckDataLoss(DecodeLidarScan(S(*foreign)), {"lidar_scan_t", "fingerprint"});
  for (const Buffer* foreign : {&s, &r, &batch}) CheckDataLoss(DecodeOdometry(S(*foreign)), {"odometry_t", "fingerprint"});
  // Ours are foreign to the robot <-> server decoders.
  CheckDataLoss(DecodeKeyframeBatch(S(s)), {"keyframe_batch_t", "fingerprint"});
  CheckDataLoss(DecodePoseUpdate(S(o)), {"pose_update_t", "fingerprint"});
  // Cut to 8 and 12 bytes: shorter than the header, still refused by the fingerprint.
  for (std::size_t len : {std::size_t{8}, std::size_t{12}}) {
    const Buffer cut(o.begin(), o.begin() + static_cast<std::ptrdiff_t>(len));
    CheckDataLoss(DecodeLidarScan(S(cut)), {"fingerprint"});
  }
  // One flipped fingerprint bit.
  Buffer flipped = s;
  flipped[7] ^= 0x01;
  CheckDataLoss(DecodeLidarScan(S(flipped)), {"fingerprint"});
}

TEST_CASE("input codec: a Velodyne-size scan and odometry travel through LcmBus into ScanOdometrySync") {
  LcmBusParams params;
  params.url = "memq://";
  auto bus = OpenLcmBus(params, {kLidarScanChannel, kOdometryChannel});
  REQUIRE(bus.ok());
  // 120 000 points (an HDL-64E scan, 1.9 MB: many UDP datagrams on a real bus) between two odometry samples.
  LidarScan scan = MakeScan(120000);
  scan.points[1] = {1.0f, 2.0f, 3.0f, 0.0f};
  scan.points[2] = {kFloatNaN, 0.0f, 0.0f, 0.0f};  // dropped by the decoder
  scan.utime_us = 1763800000050000;
  OdometrySample a, b;
  a.utime_us = 1763800000000000;
  b.utime_us = 1763800000100000;
  b.T_odom_sensor.translation() = Eigen::Vector3d(1.0, 0.0, 0.0);
  Buffer bytes;
  REQUIRE(EncodeLidarScan(scan, &bytes).ok());
  REQUIRE((*bus)->Publish(kLidarScanChannel, bytes).ok());  // the scan before the odometry that covers it
  REQUIRE(EncodeOdometry(a, &bytes).ok());
  REQUIRE((*bus)->Publish(kOdometryChannel, bytes).ok());
  REQUIRE(EncodeOdometry(b, &bytes).ok());
  REQUIRE((*bus)->Publish(kOdometryChannel, bytes).ok());

  ScanOdometrySyncParams sync_params;
  sync_params.max_points_per_scan = 131072;
  ScanOdometrySync sync(sync_params);
  LidarScanDecoder decoder;
  LidarScan decoded;
  BusMessage message;
  int received = 0;
  for (int i = 0; i < 100 && received < 3; ++i) {
    REQUIRE((*bus)->Poll(10).ok());
    while ((*bus)->Take(&message)) {
      ++received;
      const Span<const std::uint8_t> in(message.bytes.data(), message.bytes.size());
      if (message.channel == kLidarScanChannel) {
        REQUIRE(decoder.Decode(in, &decoded).ok());
        CHECK(decoded.dropped_nonfinite == 1);
        sync.PushScan(decoded);
      } else if (message.channel == kOdometryChannel) {
        auto odometry = DecodeOdometry(in);
        REQUIRE(odometry.ok());
        sync.PushOdometry(*odometry);
      }
    }
  }
  REQUIRE(received == 3);
  SyncedScan synced;
  REQUIRE(sync.PopReady(&synced));
  CHECK(synced.utime_us == scan.utime_us);
  CHECK(synced.points.size() == 120000 - 1);
  CHECK(synced.points[1].z == 3.0f);
  CHECK(synced.T_odom_sensor.translation().x() == doctest::Approx(0.5));
  CHECK((*bus)->stats().dropped_queue_full == 0);
}

}  // namespace
}  // namespace commerge::platform
