// SPDX-License-Identifier: BSD-3-Clause
// ReadPointCloud / WritePointCloud: the extension picks the format.
#include <doctest/doctest.h>

#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "platform/io/pcd.hpp"
#include "platform/io/point_cloud_file.hpp"
#include "tests/support/test_data.hpp"

namespace commerge::platform {
namespace {

using test::ScratchFile;

std::string FirstBytes(const std::string& path, std::size_t n) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  REQUIRE(f != nullptr);
  std::string bytes(n, '\0');
  bytes.resize(std::fread(&bytes[0], 1, n, f));
  std::fclose(f);
  return bytes;
}

std::vector<PointXYZI> RandomPoints(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> value(-50.0f, 50.0f);
  std::vector<PointXYZI> points(n);
  for (PointXYZI& p : points) p = PointXYZI{value(rng), value(rng), value(rng), value(rng)};
  return points;
}

TEST_CASE("point_cloud_file: the extension chooses the format, and each round-trips exactly") {
  const std::vector<PointXYZI> points = RandomPoints(200, 41);
  const std::vector<std::uint16_t> ids(points.size(), 3);
  struct Case {
    const char* name;
    const char* magic;  // first bytes of the file
    bool robot_ids;
  };
  const Case cases[] = {{"cloud.pcd", "# .PCD", true},   {"CLOUD.PCD", "# .PCD", false},
                        {"cloud.ply", "ply\n", true},    {"cloud.Ply", "ply\n", false},
                        {"cloud.bin", nullptr, false}};
  for (const Case& c : cases) {
    CAPTURE(c.name);
    const std::string path = ScratchFile(c.name);
    const Span<const std::uint16_t> robot_ids =
        c.robot_ids ? Span<const std::uint16_t>(ids) : Span<const std::uint16_t>();
    REQUIRE(WritePointCloud(path, Span<const PointXYZI>(points), robot_ids).ok());
    if (c.magic) {
      CHECK(FirstBytes(path, std::strlen(c.magic)) == c.magic);
    } else {
      CHECK(std::memcmp(FirstBytes(path, 16).data(), &points[0], 16) == 0);  // KITTI: no header
    }
    auto cloud = ReadPointCloud(path);
    REQUIRE(cloud.ok());
    REQUIRE(cloud->points.size() == points.size());
    CHECK(std::memcmp(cloud->points.data(), points.data(), points.size() * sizeof(PointXYZI)) == 0);
    CHECK(cloud->robot_ids == (c.robot_ids ? ids : std::vector<std::uint16_t>{}));
  }
}

TEST_CASE("point_cloud_file: .pcd is written binary and ascii .pcd files are read too") {
  const std::vector<PointXYZI> points = RandomPoints(20, 42);
  const std::string binary = ScratchFile("dispatch_binary.pcd");
  REQUIRE(WritePointCloud(binary, Span<const PointXYZI>(points)).ok());
  CHECK(FirstBytes(binary, 4096).find("\nDATA binary\n") != std::string::npos);

  const std::string ascii = ScratchFile("dispatch_ascii.pcd");
  REQUIRE(WritePcd(ascii, Span<const PointXYZI>(points), PcdEncoding::kAscii).ok());
  auto cloud = ReadPointCloud(ascii);
  REQUIRE(cloud.ok());
  CHECK(std::memcmp(cloud->points.data(), points.data(), points.size() * sizeof(PointXYZI)) == 0);
}

TEST_CASE("point_cloud_file: robot ids cannot go into a KITTI .bin") {
  const std::vector<PointXYZI> points(2);
  const std::vector<std::uint16_t> ids(2, 1);
  const std::string path = ScratchFile("ids.bin");
  const Status s = WritePointCloud(path, Span<const PointXYZI>(points), Span<const std::uint16_t>(ids));
  CHECK(s.code() == StatusCode::kInvalidArgument);
  CHECK(s.message().rfind(path, 0) == 0);
  CHECK(s.message().find("robot ids") != std::string::npos);
}

TEST_CASE("point_cloud_file: unknown extensions are invalid arguments listing the supported ones") {
  const std::vector<PointXYZI> points(1);
  for (const std::string name : {"cloud.las", "cloud", "cloud.pcd.gz"}) {
    CAPTURE(name);
    const std::string path = ScratchFile(name);
    const Status write = WritePointCloud(path, Span<const PointXYZI>(points));
    const Status read = ReadPointCloud(path).status();
    for (const Status& s : {write, read}) {
      CHECK(s.code() == StatusCode::kInvalidArgument);
      CHECK(s.message().rfind(path, 0) == 0);
      for (const char* ext : {".bin", ".pcd", ".ply"}) CHECK(s.message().find(ext) != std::string::npos);
    }
  }
}

}  // namespace
}  // namespace commerge::platform
