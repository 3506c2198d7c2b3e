// SPDX-License-Identifier: BSD-3-Clause
// KITTI .bin: ReadKittiBin/WriteKittiBin against records written and read with plain fwrite/fread.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "platform/io/kitti_bin.hpp"
#include "tests/support/test_data.hpp"

namespace commerge::platform {
namespace {

using test::ScratchFile;

/// Writes `bytes` bytes from `data` with plain fwrite (the independent writer).
void WriteRawFile(const std::string& path, const void* data, std::size_t bytes) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  REQUIRE(f != nullptr);
  if (bytes > 0) REQUIRE(std::fwrite(data, 1, bytes, f) == bytes);
  REQUIRE(std::fclose(f) == 0);
}

std::vector<float> RandomFloats(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> dist(-80.0f, 80.0f);
  std::vector<float> values(n);
  for (float& v : values) v = dist(rng);
  return values;
}

bool SameBitsAsRecord(const PointXYZI& p, const float* raw) { return std::memcmp(&p, raw, sizeof(PointXYZI)) == 0; }

/// Reads record `index` of a KITTI file with fseek/fread.
std::vector<float> RawRecord(const std::string& path, long index) {
  std::vector<float> record(4);
  std::FILE* f = std::fopen(path.c_str(), "rb");
  REQUIRE(f != nullptr);
  REQUIRE(std::fseek(f, index * 16, SEEK_SET) == 0);
  REQUIRE(std::fread(record.data(), sizeof(float), 4, f) == 4);
  std::fclose(f);
  return record;
}

TEST_CASE("kitti_bin: ReadKittiBin returns exactly the float32 records written by fwrite") {
  const std::string path = ScratchFile("raw.bin");
  const std::vector<float> raw = RandomFloats(4 * 1000, 7);
  WriteRawFile(path, raw.data(), raw.size() * sizeof(float));

  auto cloud = ReadKittiBin(path);
  REQUIRE(cloud.ok());
  REQUIRE(cloud->points.size() == 1000);
  CHECK(cloud->records_in_file == 1000);
  CHECK(cloud->dropped_nonfinite == 0);
  CHECK(cloud->robot_ids.empty());
  for (std::size_t i = 0; i < 1000; ++i) REQUIRE(SameBitsAsRecord(cloud->points[i], &raw[4 * i]));
}

TEST_CASE("kitti_bin: WriteKittiBin writes the points as raw 16-byte records") {
  const std::string path = ScratchFile("written.bin");
  const std::vector<float> raw = RandomFloats(4 * 300, 8);
  std::vector<PointXYZI> points;
  for (std::size_t i = 0; i < raw.size(); i += 4) points.push_back({raw[i], raw[i + 1], raw[i + 2], raw[i + 3]});
  REQUIRE(WriteKittiBin(path, Span<const PointXYZI>(points)).ok());

  REQUIRE(std::filesystem::file_size(path) == 300 * 16);
  std::vector<float> back(raw.size());
  std::FILE* f = std::fopen(path.c_str(), "rb");
  REQUIRE(f != nullptr);
  REQUIRE(std::fread(back.data(), sizeof(float), back.size(), f) == back.size());
  std::fclose(f);
  CHECK(std::memcmp(back.data(), raw.data(), raw.size() * sizeof(float)) == 0);
}

TEST_CASE("kitti_bin: a file of 16k+5 bytes is data loss naming the path") {
  const std::string path = ScratchFile("truncated.bin");
  const std::vector<unsigned char> bytes(16 * 10 + 5, 0);
  WriteRawFile(path, bytes.data(), bytes.size());

  auto cloud = ReadKittiBin(path);
  REQUIRE_FALSE(cloud.ok());
  CHECK(cloud.status().code() == StatusCode::kDataLoss);
  CHECK(cloud.status().message().find(path) == 0);
  CHECK(cloud.status().message().find("165") != std::string::npos);
}

TEST_CASE("kitti_bin: a missing file is not found, naming the path") {
  const std::string path = ScratchFile("does_not_exist.bin");
  auto cloud = ReadKittiBin(path);
  REQUIRE_FALSE(cloud.ok());
  CHECK(cloud.status().code() == StatusCode::kNotFound);
  CHECK(cloud.status().message().find(path) == 0);
}

TEST_CASE("kitti_bin: NaN and inf points are dropped and counted, the others keep their order") {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const float raw[] = {1, 2, 3, 0.5f,  nan, 0, 0, 1,  4, 5, 6, 0.25f,  0, -inf, 0, 1,
                       0, 0, inf, 1,   7, 8, 9, nan,  -1, -2, -3, 0};
  const std::string path = ScratchFile("nonfinite.bin");
  WriteRawFile(path, raw, sizeof(raw));

  auto cloud = ReadKittiBin(path);
  REQUIRE(cloud.ok());
  CHECK(cloud->records_in_file == 7);
  CHECK(cloud->dropped_nonfinite == 3);
  REQUIRE(cloud->points.size() == 4);
  CHECK(SameBitsAsRecord(cloud->points[0], &raw[0]));
  CHECK(SameBitsAsRecord(cloud->points[1], &raw[8]));
  CHECK(SameBitsAsRecord(cloud->points[2], &raw[20]));  // NaN intensity is kept: only x, y, z are checked
  CHECK(SameBitsAsRecord(cloud->points[3], &raw[24]));
}

TEST_CASE("kitti_bin: an empty file is a valid scan with no points") {
  const std::string path = ScratchFile("empty.bin");
  WriteRawFile(path, nullptr, 0);
  auto cloud = ReadKittiBin(path);
  REQUIRE(cloud.ok());
  CHECK(cloud->points.empty());
  CHECK(cloud->records_in_file == 0);
  CHECK(cloud->dropped_nonfinite == 0);
}

TEST_CASE("kitti_bin: every KITTI 00 scan reads back with size/16 points equal to the raw bytes") {
  CM_SHARED_DATA_OR_SKIP(dir, "kitti/kitti00_frames0-15");
  int scans = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir + "/velodyne")) {
    if (entry.path().extension() != ".bin") continue;
    const std::string path = entry.path().string();
    CAPTURE(path);
    const auto bytes = std::filesystem::file_size(path);
    auto cloud = ReadKittiBin(path);
    REQUIRE(cloud.ok());
    REQUIRE(cloud->points.size() == bytes / 16);
    CHECK(cloud->records_in_file == bytes / 16);
    CHECK(cloud->dropped_nonfinite == 0);
    const long last = static_cast<long>(bytes / 16) - 1;
    CHECK(SameBitsAsRecord(cloud->points.front(), RawRecord(path, 0).data()));
    CHECK(SameBitsAsRecord(cloud->points.back(), RawRecord(path, last).data()));
    ++scans;
  }
  CHECK(scans == 16);
}

}  // namespace
}  // namespace commerge::platform
