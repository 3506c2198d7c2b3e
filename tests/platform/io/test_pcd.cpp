// SPDX-License-Identifier: BSD-3-Clause
// PCD: round trips through WritePcd/ReadPcd, hand-written files (header text + fwrite'd records) to check
// the parser independently of our writer, and malformed files.
#include <doctest/doctest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "platform/io/pcd.hpp"
#include "tests/platform/io/io_test_util.hpp"
#include "tests/support/test_data.hpp"

namespace commerge::platform {
namespace {

struct Cloud {
  std::vector<PointXYZI> points;
  std::vector<std::uint16_t> robot_ids;
};

/// Random points over several magnitudes, plus values that stress text round trips.
Cloud RandomCloud(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> mantissa(-1.0f, 1.0f);
  std::uniform_int_distribution<int> exponent(-20, 20);
  std::uniform_int_distribution<int> robot(0, 65535);
  Cloud cloud;
  for (std::size_t i = 0; i < n; ++i) {
    auto value = [&] { return std::ldexp(mantissa(rng), exponent(rng)); };
    cloud.points.push_back(PointXYZI{value(), value(), value(), value()});
    cloud.robot_ids.push_back(static_cast<std::uint16_t>(robot(rng)));
  }
  const float extremes[] = {-0.0f, std::numeric_limits<float>::max(), std::numeric_limits<float>::lowest(),
                            std::numeric_limits<float>::min(), std::numeric_limits<float>::denorm_min(),
                            0.1f, 1.0f / 3.0f, 16777217.0f};
  for (const float e : extremes) cloud.points.push_back(PointXYZI{e, -e, e, e});
  cloud.robot_ids.resize(cloud.points.size(), 65535);
  return cloud;
}

void CheckSameCloud(const PointCloudFile& read, const Cloud& written, bool with_robot) {
  REQUIRE(read.points.size() == written.points.size());
  CHECK(read.records_in_file == written.points.size());
  CHECK(read.dropped_nonfinite == 0);
  for (std::size_t i = 0; i < written.points.size(); ++i) {
    CAPTURE(i);
    REQUIRE(SameBits(read.points[i], written.points[i]));
  }
  if (with_robot) {
    CHECK(read.robot_ids == written.robot_ids);
  } else {
    CHECK(read.robot_ids.empty());
  }
}

const std::string kXyziHeader =
    "VERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\n";

TEST_CASE("pcd: binary and ascii round trips are bit-exact, with and without robot ids") {
  const Cloud cloud = RandomCloud(500, 21);
  for (const PcdEncoding encoding : {PcdEncoding::kBinary, PcdEncoding::kAscii}) {
    for (const bool with_robot : {false, true}) {
      CAPTURE(encoding == PcdEncoding::kAscii);
      CAPTURE(with_robot);
      const std::string path = ScratchFile("roundtrip.pcd");
      const Span<const std::uint16_t> ids = with_robot ? Span<const std::uint16_t>(cloud.robot_ids)
                                                       : Span<const std::uint16_t>();
      REQUIRE(WritePcd(path, Span<const PointXYZI>(cloud.points), encoding, ids).ok());
      auto read = ReadPcd(path);
      REQUIRE(read.ok());
      CheckSameCloud(*read, cloud, with_robot);
    }
  }
}

TEST_CASE("pcd: an empty cloud round-trips in both encodings") {
  for (const PcdEncoding encoding : {PcdEncoding::kBinary, PcdEncoding::kAscii}) {
    const std::string path = ScratchFile("empty.pcd");
    REQUIRE(WritePcd(path, Span<const PointXYZI>(), encoding).ok());
    auto read = ReadPcd(path);
    REQUIRE(read.ok());
    CHECK(read->points.empty());
    CHECK(read->records_in_file == 0);
  }
}

TEST_CASE("pcd: hand-written binary file with fields in odd order, extra fields and mixed types") {
  const std::string header =
      "# .PCD v0.7 - hand-written\n"
      "VERSION 0.7\n"
      "FIELDS intensity z normal y _ x robot\n"
      "SIZE 8 4 4 8 1 4 2\n"
      "TYPE F F F F U I U\n"
      "COUNT 1 1 3 1 3 1 1\n"
      "WIDTH 3\n"
      "HEIGHT 1\n"
      "VIEWPOINT 0 0 0 1 0 0 0\n"
      "POINTS 3\n"
      "DATA binary\n";
  Bytes b;
  // intensity(f64) z(f32) normal(3 x f32) y(f64) _(3 x u8) x(i32) robot(u16)
  using U8 = std::uint8_t;
  b.Put(0.25).Put(3.5f).Put(9.f).Put(9.f).Put(9.f).Put(-2.0).Put<U8>(1).Put<U8>(2).Put<U8>(3);
  b.Put<std::int32_t>(-5).Put<std::uint16_t>(7);
  b.Put(1e-3).Put(-0.125f).Put(0.f).Put(0.f).Put(0.f).Put(1e5).Put<U8>(0).Put<U8>(0).Put<U8>(0);
  b.Put<std::int32_t>(100000).Put<std::uint16_t>(65535);
  b.Put(7.0).Put(std::nanf("")).Put(0.f).Put(0.f).Put(0.f).Put(0.0).Put<U8>(0).Put<U8>(0).Put<U8>(0);
  b.Put<std::int32_t>(1).Put<std::uint16_t>(3);
  REQUIRE(b.data.size() == 3 * 41);
  const std::string path = WriteFile("odd_binary.pcd", header, b.data + "trailing bytes are ignored");

  auto cloud = ReadPcd(path);
  REQUIRE(cloud.ok());
  CHECK(cloud->records_in_file == 3);
  CHECK(cloud->dropped_nonfinite == 1);
  REQUIRE(cloud->points.size() == 2);
  CHECK(SameBits(cloud->points[0], PointXYZI{-5.0f, -2.0f, 3.5f, 0.25f}));
  CHECK(SameBits(cloud->points[1], PointXYZI{100000.0f, 1e5f, -0.125f, static_cast<float>(1e-3)}));
  CHECK(cloud->robot_ids == std::vector<std::uint16_t>{7, 65535});
}

TEST_CASE("pcd: hand-written ascii file without POINTS and with an extra field") {
  const std::string path = WriteFile("odd_ascii.pcd",
                                     "# comment line\n"
                                     "VERSION .7\n"
                                     "FIELDS rgb x intensity y z\n"
                                     "SIZE 4 8 1 4 4\n"
                                     "TYPE F F U F F\n"
                                     "WIDTH 2\n"
                                     "HEIGHT 2\n"
                                     "DATA ascii\n"
                                     "4.2108e+06 1.5 200 -2.25 3\n"
                                     "0 nan 0 0 0\n"
                                     "0\t-1e-7  1   +2 0.1\r\n"
                                     "0 0 0 inf 0\n"
                                     "\n");
  auto cloud = ReadPcd(path);
  REQUIRE(cloud.ok());
  CHECK(cloud->records_in_file == 4);
  CHECK(cloud->dropped_nonfinite == 2);
  REQUIRE(cloud->points.size() == 2);
  CHECK(SameBits(cloud->points[0], PointXYZI{1.5f, -2.25f, 3.0f, 200.0f}));
  CHECK(SameBits(cloud->points[1], PointXYZI{static_cast<float>(-1e-7), 2.0f, 0.1f, 1.0f}));
  CHECK(cloud->robot_ids.empty());
}

TEST_CASE("pcd: intensity is 0 when the file has no intensity field") {
  Bytes b;
  b.Put(1.f).Put(2.f).Put(3.f);
  const std::string path = WriteFile(
      "xyz.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA binary\n", b.data);
  auto cloud = ReadPcd(path);
  REQUIRE(cloud.ok());
  REQUIRE(cloud->points.size() == 1);
  CHECK(SameBits(cloud->points[0], PointXYZI{1.f, 2.f, 3.f, 0.f}));
}

TEST_CASE("pcd: intensity aliases rank below 'intensity', and a coordinate given twice is an error") {
  const std::string tail = "WIDTH 1\nHEIGHT 1\nDATA ascii\n1 2 3 4 5\n";
  const std::string aliases = WriteFile(
      "aliases.pcd", "FIELDS reflectance x y z intensity\nSIZE 4 4 4 4 4\nTYPE F F F F F\n" + tail);
  auto cloud = ReadPcd(aliases);
  REQUIRE(cloud.ok());
  REQUIRE(cloud->points.size() == 1);
  CHECK(SameBits(cloud->points[0], PointXYZI{2.f, 3.f, 4.f, 5.f}));

  const std::string alias_only =
      WriteFile("alias_only.pcd", "FIELDS x y z scalar_intensity robot\nSIZE 4 4 4 4 1\nTYPE F F F F U\n" + tail);
  cloud = ReadPcd(alias_only);
  REQUIRE(cloud.ok());
  CHECK(SameBits(cloud->points[0], PointXYZI{1.f, 2.f, 3.f, 4.f}));
  CHECK(cloud->robot_ids == std::vector<std::uint16_t>{5});

  const std::string twice = WriteFile("x_twice.pcd", "FIELDS x y z x\nSIZE 4 4 4 4\nTYPE F F F F\n" + tail);
  CHECK(ReadPcd(twice).status().code() == StatusCode::kDataLoss);
  CHECK(ReadPcd(twice).status().message().find("field 'x' appears twice") != std::string::npos);
}

TEST_CASE("pcd: a header announcing 10^12 points over a tiny file fails quickly without allocating") {
  Bytes b;
  b.Put(1.f).Put(2.f).Put(3.f).Put(4.f).Put(5.f).Put(6.f).Put(7.f).Put(8.f);
  const std::string sizes = "WIDTH 1000000000000\nHEIGHT 1\nPOINTS 1000000000000\n";
  const auto start = std::chrono::steady_clock::now();
  const std::string binary = WriteFile("huge_binary.pcd", kXyziHeader + sizes + "DATA binary\n", b.data);
  auto cloud = ReadPcd(binary);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, binary,
             {"truncated: header announces 1000000000000 points = 16000000000000 bytes, file has 32 bytes after the "
              "header"});

  const std::string ascii = WriteFile("huge_ascii.pcd", kXyziHeader + sizes + "DATA ascii\n", "1 2 3 4\n");
  cloud = ReadPcd(ascii);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, ascii, {"truncated", "1000000000000 points"});
  CHECK(std::chrono::steady_clock::now() - start < std::chrono::seconds(5));
}

TEST_CASE("pcd: binary data shorter than POINTS records is truncated data") {
  Bytes b;
  for (int i = 0; i < 38; ++i) b.Put(static_cast<float>(i));  // 9.5 records of 16 bytes
  const std::string path = WriteFile("short.pcd", kXyziHeader + "WIDTH 10\nHEIGHT 1\nPOINTS 10\nDATA binary\n", b.data);
  auto cloud = ReadPcd(path);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, path,
             {"truncated: header announces 10 points = 160 bytes, file has 152 bytes after the header"});
}

TEST_CASE("pcd: ascii rows with the wrong number of values name the line") {
  const std::string header = kXyziHeader + "WIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA ascii\n";  // 9 header lines
  const std::string short_row = WriteFile("short_row.pcd", header, "1 2 3 4\n1 2 3\n1 2 3 4\n");
  auto cloud = ReadPcd(short_row);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, short_row, {"line 11", "expected 4 values, found 3"});

  const std::string bad_token = WriteFile("bad_token.pcd", header, "1 2 3 4\n1 2 3 4\n1 2 x3 4\n");
  cloud = ReadPcd(bad_token);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, bad_token, {"line 12", "'x3' is not a number"});

  const std::string few_rows = WriteFile("few_rows.pcd", header, "1 2 3 4\n1 2 3 4\n");
  cloud = ReadPcd(few_rows);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, few_rows, {"truncated"});

  const std::string many_rows = WriteFile("many_rows.pcd", header, "1 2 3 4\n1 2 3 4\n1 2 3 4\n\n5 6 7 8\n");
  cloud = ReadPcd(many_rows);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, many_rows, {"line 14", "more data rows"});
}

TEST_CASE("pcd: malformed headers are errors naming the file") {
  const std::string tail = "WIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3 4\n";
  struct Case {
    std::string name, text;
    StatusCode code;
    std::vector<std::string> parts;
  };
  const Case cases[] = {
      {"no_x.pcd", "FIELDS y z intensity X\nSIZE 4 4 4 4\nTYPE F F F F\n" + tail, StatusCode::kInvalidArgument,
       {"no field 'x'"}},
      {"no_size.pcd", "FIELDS x y z intensity\nTYPE F F F F\n" + tail, StatusCode::kDataLoss, {"no SIZE line"}},
      {"no_height.pcd", kXyziHeader + "WIDTH 1\nPOINTS 1\nDATA ascii\n1 2 3 4\n", StatusCode::kDataLoss,
       {"no HEIGHT line"}},
      {"size_count.pcd", "FIELDS x y z intensity\nSIZE 4 4 4\nTYPE F F F F\n" + tail, StatusCode::kDataLoss,
       {"line 2", "SIZE has 3 values, but FIELDS names 4"}},
      {"points_mismatch.pcd", kXyziHeader + "WIDTH 2\nHEIGHT 3\nPOINTS 5\nDATA ascii\n", StatusCode::kDataLoss,
       {"line 8", "POINTS 5 is not WIDTH x HEIGHT = 2 x 3"}},
      {"bad_type.pcd", "FIELDS x y z intensity\nSIZE 4 4 2 4\nTYPE F F F F\n" + tail, StatusCode::kDataLoss,
       {"field 'z' has TYPE F with SIZE 2"}},
      {"unknown_key.pcd", "VERSION 0.7\nCOLOUR red\n" + tail, StatusCode::kDataLoss,
       {"line 2", "unknown header key 'COLOUR'"}},
      {"twice.pcd", kXyziHeader + "WIDTH 1\n" + tail, StatusCode::kDataLoss, {"second WIDTH line"}},
      {"no_data.pcd", kXyziHeader + "WIDTH 1\nHEIGHT 1\n", StatusCode::kDataLoss, {"without a DATA line"}},
      {"bad_width.pcd", kXyziHeader + "WIDTH -3\nHEIGHT 1\nDATA ascii\n", StatusCode::kDataLoss,
       {"WIDTH expects one non-negative integer"}},
      {"bad_data.pcd", kXyziHeader + "WIDTH 1\nHEIGHT 1\nDATA text\n", StatusCode::kDataLoss, {"DATA expects"}},
      {"compressed.pcd", kXyziHeader + "WIDTH 1\nHEIGHT 1\nDATA binary_compressed\n", StatusCode::kDataLoss,
       {"truncated: DATA binary_compressed needs 8 bytes of sizes after the header, the file has 0"}},
      {"huge_count.pcd", "FIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 4294967296\n" + tail,
       StatusCode::kDataLoss, {"field 'intensity' has count 4294967296"}},
      {"garbage.pcd", std::string(100000, '\x7f'), StatusCode::kDataLoss, {"line 1", "not a text header"}},
      {"empty.pcd", "", StatusCode::kDataLoss, {"without a DATA line"}},
  };
  for (const Case& c : cases) {
    CAPTURE(c.name);
    const std::string path = WriteFile(c.name, c.text);
    auto cloud = ReadPcd(path);
    REQUIRE_FALSE(cloud.ok());
    CheckError(cloud.status(), c.code, path, c.parts);
  }
}

TEST_CASE("pcd: robot values that are not ids in 0..65535 are rejected") {
  const std::string header = "FIELDS x y z robot\nSIZE 4 4 4 4\nTYPE F F F F\nWIDTH 2\nHEIGHT 1\nDATA ascii\n";
  for (const char* robot : {"1.5", "-1", "65536", "nan"}) {
    CAPTURE(robot);
    const std::string path = WriteFile("bad_robot.pcd", header, "1 2 3 4\n1 2 3 " + std::string(robot) + "\n");
    auto cloud = ReadPcd(path);
    REQUIRE_FALSE(cloud.ok());
    CheckError(cloud.status(), StatusCode::kDataLoss, path, {"line 8", "robot id", "0..65535"});
  }
}

TEST_CASE("pcd: WritePcd rejects robot ids that do not match the points and ReadPcd reports missing files") {
  const std::vector<PointXYZI> points(3);
  const std::vector<std::uint16_t> ids(2);
  const std::string path = ScratchFile("mismatch.pcd");
  const Status s = WritePcd(path, Span<const PointXYZI>(points), PcdEncoding::kBinary, Span<const std::uint16_t>(ids));
  CheckError(s, StatusCode::kInvalidArgument, path, {"2 robot ids for 3 points"});

  const std::string missing = ScratchFile("missing.pcd");
  CheckError(ReadPcd(missing).status(), StatusCode::kNotFound, missing, {});
}

}  // namespace
}  // namespace commerge::platform
