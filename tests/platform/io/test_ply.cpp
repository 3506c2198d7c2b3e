// SPDX-License-Identifier: BSD-3-Clause
// PLY: round trips through WritePly/ReadPly, hand-written files (header text + fwrite'd records) to check
// the parser independently of our writer, and malformed or unsupported files.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "platform/io/ply.hpp"
#include "tests/platform/io/io_test_util.hpp"
#include "tests/support/test_data.hpp"

namespace commerge::platform {
namespace {

const std::string kXyziVertex =
    "property float x\nproperty float y\nproperty float z\nproperty float intensity\nend_header\n";

TEST_CASE("ply: binary round trip is bit-exact, with and without robot ids") {
  std::mt19937 rng(31);
  std::uniform_real_distribution<float> value(-1000.0f, 1000.0f);
  std::uniform_int_distribution<int> robot(0, 65535);
  std::vector<PointXYZI> points(700);
  std::vector<std::uint16_t> ids(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    points[i] = PointXYZI{value(rng), value(rng), value(rng), value(rng)};
    ids[i] = static_cast<std::uint16_t>(robot(rng));
  }
  for (const bool with_robot : {false, true}) {
    CAPTURE(with_robot);
    const std::string path = ScratchFile("roundtrip.ply");
    const Span<const std::uint16_t> robot_ids =
        with_robot ? Span<const std::uint16_t>(ids) : Span<const std::uint16_t>();
    REQUIRE(WritePly(path, Span<const PointXYZI>(points), robot_ids).ok());
    auto cloud = ReadPly(path);
    REQUIRE(cloud.ok());
    REQUIRE(cloud->points.size() == points.size());
    CHECK(cloud->records_in_file == points.size());
    for (std::size_t i = 0; i < points.size(); ++i) REQUIRE(SameBits(cloud->points[i], points[i]));
    CHECK(cloud->robot_ids == (with_robot ? ids : std::vector<std::uint16_t>{}));
  }
}

TEST_CASE("ply: WritePly writes the documented header and 18-byte records") {
  const std::vector<PointXYZI> points = {{1, 2, 3, 4}, {5, 6, 7, 8}};
  const std::vector<std::uint16_t> ids = {9, 10};
  const std::string path = ScratchFile("layout.ply");
  REQUIRE(WritePly(path, Span<const PointXYZI>(points), Span<const std::uint16_t>(ids)).ok());

  std::FILE* f = std::fopen(path.c_str(), "rb");
  REQUIRE(f != nullptr);
  std::string content(4096, '\0');
  content.resize(std::fread(&content[0], 1, content.size(), f));
  std::fclose(f);
  const std::string header = "ply\nformat binary_little_endian 1.0\n";
  CHECK(content.rfind(header, 0) == 0);
  const std::size_t end = content.find("end_header\n");
  REQUIRE(end != std::string::npos);
  CHECK(content.find("element vertex 2\n") != std::string::npos);
  CHECK(content.find("property float x\nproperty float y\nproperty float z\nproperty float intensity\n"
                     "property ushort robot\nend_header\n") != std::string::npos);
  Bytes expected;
  expected.Put(1.f).Put(2.f).Put(3.f).Put(4.f).Put<std::uint16_t>(9);
  expected.Put(5.f).Put(6.f).Put(7.f).Put(8.f).Put<std::uint16_t>(10);
  CHECK(content.substr(end + 11) == expected.data);
}

TEST_CASE("ply: hand-written binary file with odd property order and types, faces after the vertices") {
  const std::string header =
      "ply\n"
      "format binary_little_endian 1.0\n"
      "comment hand-written\n"
      "obj_info test\n"
      "element vertex 3\n"
      "property uchar intensity\n"
      "property double z\n"
      "property int16 extra\n"
      "property float32 y\n"
      "property ushort robot\n"
      "property int x\n"
      "element face 1\n"
      "property list uchar int vertex_indices\n"
      "end_header\n";
  Bytes b;  // intensity(u8) z(f64) extra(i16) y(f32) robot(u16) x(i32)
  b.Put<std::uint8_t>(200).Put(-1.5).Put<std::int16_t>(-7).Put(2.25f).Put<std::uint16_t>(4).Put<std::int32_t>(-3);
  b.Put<std::uint8_t>(0).Put(1e300).Put<std::int16_t>(0).Put(0.f).Put<std::uint16_t>(5).Put<std::int32_t>(0);
  b.Put<std::uint8_t>(17).Put(0.5).Put<std::int16_t>(0).Put(1e-3f).Put<std::uint16_t>(6).Put<std::int32_t>(123456);
  b.Put<std::uint8_t>(3).Put<std::int32_t>(0).Put<std::int32_t>(1).Put<std::int32_t>(2);  // the face
  const std::string path = WriteFile("odd_binary.ply", header, b.data);

  auto cloud = ReadPly(path);
  REQUIRE(cloud.ok());
  CHECK(cloud->records_in_file == 3);
  CHECK(cloud->dropped_nonfinite == 1);  // z = 1e300 is inf as a float
  REQUIRE(cloud->points.size() == 2);
  CHECK(SameBits(cloud->points[0], PointXYZI{-3.f, 2.25f, -1.5f, 200.f}));
  CHECK(SameBits(cloud->points[1], PointXYZI{123456.f, 1e-3f, 0.5f, 17.f}));
  CHECK(cloud->robot_ids == std::vector<std::uint16_t>{4, 6});
}

TEST_CASE("ply: hand-written ascii file, scalar_intensity alias, faces ignored") {
  const std::string path = WriteFile("ascii.ply",
                                     "ply\r\n"
                                     "format ascii 1.0\r\n"
                                     "element vertex 3\r\n"
                                     "property float64 x\r\n"
                                     "property float y\r\n"
                                     "property float z\r\n"
                                     "property float scalar_intensity\r\n"
                                     "element face 1\r\n"
                                     "property list uchar int vertex_indices\r\n"
                                     "end_header\r\n"
                                     "1 2 3 4\r\n"
                                     "-0.5 0.25 nan 9\r\n"
                                     "1e-3 -2 7 0\r\n"
                                     "3 0 1 2\r\n");
  auto cloud = ReadPly(path);
  REQUIRE(cloud.ok());
  CHECK(cloud->records_in_file == 3);
  CHECK(cloud->dropped_nonfinite == 1);
  REQUIRE(cloud->points.size() == 2);
  CHECK(SameBits(cloud->points[0], PointXYZI{1.f, 2.f, 3.f, 4.f}));
  CHECK(SameBits(cloud->points[1], PointXYZI{static_cast<float>(1e-3), -2.f, 7.f, 0.f}));
  CHECK(cloud->robot_ids.empty());
}

TEST_CASE("ply: a vertex count of 10^12 over a tiny file fails without allocating") {
  const std::string huge = "element vertex 1000000000000\n" + kXyziVertex;
  const std::string path =
      WriteFile("huge.ply", "ply\nformat binary_little_endian 1.0\n" + huge, std::string(32, '\0'));
  auto cloud = ReadPly(path);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, path,
             {"truncated: header announces 1000000000000 points = 16000000000000 bytes, file has 32 bytes after the "
              "header"});

  const std::string ascii = WriteFile("huge_ascii.ply", "ply\nformat ascii 1.0\n" + huge, "1 2 3 4\n");
  cloud = ReadPly(ascii);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, ascii, {"truncated", "1000000000000 points"});
}

TEST_CASE("ply: truncated binary vertex data") {
  const std::string path = WriteFile(
      "short.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 4\n" + kXyziVertex, std::string(60, '\0'));
  auto cloud = ReadPly(path);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, path,
             {"truncated: header announces 4 points = 64 bytes, file has 60 bytes after the header"});
}

TEST_CASE("ply: unsupported variants and malformed headers are errors naming the file") {
  const std::string vertex = "element vertex 1\n";
  struct Case {
    std::string name, text;
    StatusCode code;
    std::vector<std::string> parts;
  };
  const Case cases[] = {
      {"big_endian.ply", "ply\nformat binary_big_endian 1.0\n" + vertex + kXyziVertex, StatusCode::kUnimplemented,
       {"binary_big_endian", "not supported"}},
      {"vertex_list.ply",
       "ply\nformat ascii 1.0\n" + vertex +
           "property list uchar float x\nproperty float y\nproperty float z\nend_header\n",
       StatusCode::kUnimplemented, {"'x' is a list"}},
      {"face_first.ply", "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n" + vertex +
                             kXyziVertex,
       StatusCode::kUnimplemented, {"element 'face' comes before the vertex element"}},
      {"no_y.ply", "ply\nformat ascii 1.0\n" + vertex + "property float x\nproperty float z\nend_header\n1 2\n",
       StatusCode::kInvalidArgument, {"no field 'y'"}},
      {"not_ply.ply", "PLY\nformat ascii 1.0\n", StatusCode::kDataLoss, {"not a PLY file"}},
      {"no_end.ply", "ply\nformat ascii 1.0\n" + vertex + "property float x\n", StatusCode::kDataLoss,
       {"without an end_header line"}},
      {"no_format.ply", "ply\n" + vertex + kXyziVertex, StatusCode::kDataLoss, {"no format line"}},
      {"bad_version.ply", "ply\nformat ascii 2.0\n", StatusCode::kDataLoss, {"line 2", "format"}},
      {"bad_type.ply", "ply\nformat ascii 1.0\n" + vertex + "property float128 x\n", StatusCode::kDataLoss,
       {"line 4", "property <scalar type> <name>"}},
      {"bad_keyword.ply", "ply\nformat ascii 1.0\nvertices 3\n", StatusCode::kDataLoss,
       {"line 3", "unknown header keyword 'vertices'"}},
      {"no_vertex.ply", "ply\nformat ascii 1.0\nend_header\n", StatusCode::kInvalidArgument, {"no vertex element"}},
      {"short_row.ply", "ply\nformat ascii 1.0\n" + vertex + kXyziVertex + "1 2 3\n", StatusCode::kDataLoss,
       {"line 9", "expected 4 values, found 3"}},
  };
  for (const Case& c : cases) {
    CAPTURE(c.name);
    const std::string path = WriteFile(c.name, c.text);
    auto cloud = ReadPly(path);
    REQUIRE_FALSE(cloud.ok());
    CheckError(cloud.status(), c.code, path, c.parts);
  }
}

TEST_CASE("ply: WritePly rejects robot ids that do not match the points") {
  const std::vector<PointXYZI> points(2);
  const std::vector<std::uint16_t> ids(5);
  const std::string path = ScratchFile("mismatch.ply");
  CheckError(WritePly(path, Span<const PointXYZI>(points), Span<const std::uint16_t>(ids)),
             StatusCode::kInvalidArgument, path, {"5 robot ids for 2 points"});
}

}  // namespace
}  // namespace commerge::platform
