// SPDX-License-Identifier: BSD-3-Clause
// PCD DATA binary_compressed: files written by PCL itself (the bytes below), and malformed variants of them.
#include <doctest/doctest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "platform/io/pcd.hpp"
#include "tests/platform/io/io_test_util.hpp"
#include "tests/support/test_data.hpp"

namespace commerge::platform {
namespace pcd_compressed_test {

// The fixtures were written by PCL 1.13 (Debian pcl-tools 1.13.0+dfsg-3) from ascii files:
//   pcl_convert_pcd_ascii_binary xyzi.pcd xyzi_c.pcd 2     (2 = binary_compressed)
// xyzi.pcd (ascii, FIELDS x y z intensity, all F 4) held the rows
//   1.5 -2.25 3 0.5 (three times) / 0.1 100.125 -7 255 / nan nan nan 0
// mixed.pcd (ascii, FIELDS t x y z ring intensity pair, SIZE 4 4 4 4 2 4 1, TYPE U F F F U F I, COUNT 1 1 1 1 1 1 2,
// WIDTH 12 HEIGHT 4) held, for i = 0..47, the row
//   1000 i | (i % 8) 0.5 - 2 | (i / 8) 0.25 | -1.5 + 0.0625 i | i % 16 | (i % 4) 10 | i % 3 - 1, -(i % 5)
// made by /usr/bin/python3 with "%d %r %r %r %d %r %d %d". Below: each output's header, then its data block
// (uint32 compressed size, uint32 uncompressed size, the LZF bytes). PCL pads the file with zeros to 4096 bytes;
// the padding is left out here and appended by PaddedFile (the mixed block holds 10 back references with an
// extended length byte).
const std::string kPclXyziHeader =
    "# .PCD v0.7 - Point Cloud Data file format\n"
    "VERSION 0.7\n"
    "FIELDS x y z intensity\n"
    "SIZE 4 4 4 4\n"
    "TYPE F F F F\n"
    "COUNT 1 1 1 1\n"
    "WIDTH 5\n"
    "HEIGHT 1\n"
    "VIEWPOINT 0 0 0 1 0 0 0\n"
    "POINTS 5\n"
    "DATA binary_compressed\n"
;
constexpr unsigned char kPclXyziBlock[] = {
    0x39, 0x00, 0x00, 0x00, 0x50, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0xc0, 0x3f, 0x00, 0xa0, 0x03,
    0x03, 0xcd, 0xcc, 0xcc, 0x3d, 0x20, 0x0b, 0x04, 0x7f, 0x00, 0x00, 0x10, 0xc0, 0xe0, 0x00, 0x03,
    0x04, 0x40, 0xc8, 0x42, 0x00, 0x00, 0x40, 0x13, 0x02, 0x40, 0x40, 0x00, 0xe0, 0x00, 0x03, 0x00,
    0xe0, 0x20, 0x1f, 0x40, 0x13, 0x00, 0x00, 0x20, 0x3b, 0xc0, 0x03, 0x02, 0x7f, 0x43, 0x00, 0x20,
    0x00,
};
const std::string kPclMixedHeader =
    "# .PCD v0.7 - Point Cloud Data file format\n"
    "VERSION 0.7\n"
    "FIELDS t x y z ring intensity pair\n"
    "SIZE 4 4 4 4 2 4 1\n"
    "TYPE U F F F U F I\n"
    "COUNT 1 1 1 1 1 1 2\n"
    "WIDTH 12\n"
    "HEIGHT 4\n"
    "VIEWPOINT 0 0 0 1 0 0 0\n"
    "POINTS 48\n"
    "DATA binary_compressed\n"
;
constexpr unsigned char kPclMixedBlock[] = {
    0x07, 0x02, 0x00, 0x00, 0x80, 0x04, 0x00, 0x00, 0x1f, 0x00, 0x00, 0x00, 0x00, 0xe8, 0x03, 0x00,
    0x00, 0xd0, 0x07, 0x00, 0x00, 0xb8, 0x0b, 0x00, 0x00, 0xa0, 0x0f, 0x00, 0x00, 0x88, 0x13, 0x00,
    0x00, 0x70, 0x17, 0x00, 0x00, 0x58, 0x1b, 0x00, 0x00, 0x1f, 0x40, 0x1f, 0x00, 0x00, 0x28, 0x23,
    0x00, 0x00, 0x10, 0x27, 0x00, 0x00, 0xf8, 0x2a, 0x00, 0x00, 0xe0, 0x2e, 0x00, 0x00, 0xc8, 0x32,
    0x00, 0x00, 0xb0, 0x36, 0x00, 0x00, 0x98, 0x3a, 0x00, 0x00, 0x1f, 0x80, 0x3e, 0x00, 0x00, 0x68,
    0x42, 0x00, 0x00, 0x50, 0x46, 0x00, 0x00, 0x38, 0x4a, 0x00, 0x00, 0x20, 0x4e, 0x00, 0x00, 0x08,
    0x52, 0x00, 0x00, 0xf0, 0x55, 0x00, 0x00, 0xd8, 0x59, 0x00, 0x00, 0x1d, 0xc0, 0x5d, 0x00, 0x00,
    0xa8, 0x61, 0x00, 0x00, 0x90, 0x65, 0x00, 0x00, 0x78, 0x69, 0x00, 0x00, 0x60, 0x6d, 0x00, 0x00,
    0x48, 0x71, 0x00, 0x00, 0x30, 0x75, 0x00, 0x00, 0x18, 0x79, 0x20, 0x7c, 0x00, 0x7d, 0x20, 0x7f,
    0x00, 0x80, 0x20, 0x7f, 0x00, 0x84, 0x20, 0x7f, 0x00, 0x88, 0x20, 0x7f, 0x00, 0x8c, 0x20, 0x7f,
    0x00, 0x90, 0x20, 0x7f, 0x00, 0x94, 0x20, 0x7f, 0x00, 0x98, 0x20, 0x7f, 0x00, 0x9c, 0x20, 0x7f,
    0x00, 0xa0, 0x20, 0x7f, 0x00, 0xa4, 0x20, 0x7f, 0x00, 0xa7, 0x20, 0x7f, 0x00, 0xab, 0x20, 0x7f,
    0x00, 0xaf, 0x20, 0x7f, 0x00, 0xb3, 0x20, 0x7f, 0x00, 0xb7, 0x20, 0x3f, 0x20, 0x62, 0x20, 0x02,
    0x00, 0xbf, 0x20, 0x89, 0x20, 0x03, 0x00, 0x00, 0x40, 0x03, 0x40, 0x00, 0x00, 0x3f, 0x20, 0x0f,
    0x20, 0x03, 0x00, 0xc0, 0x20, 0x03, 0x00, 0x00, 0xe0, 0x97, 0x1f, 0xe0, 0x16, 0x00, 0x41, 0x61,
    0xe0, 0x13, 0x03, 0x40, 0xeb, 0xe0, 0x13, 0x03, 0x00, 0x40, 0x21, 0x03, 0xe0, 0x13, 0x03, 0x41,
    0x27, 0xe0, 0x13, 0x03, 0x00, 0xa0, 0x20, 0x3f, 0xe0, 0x13, 0x03, 0x41, 0x7b, 0x00, 0xb8, 0x21,
    0x77, 0x00, 0xb0, 0x20, 0x03, 0x00, 0xa8, 0x20, 0x03, 0x00, 0xa0, 0x20, 0x03, 0x00, 0x98, 0x20,
    0x03, 0x00, 0x90, 0x20, 0x03, 0x00, 0x88, 0x20, 0x03, 0x41, 0x97, 0x00, 0x70, 0x20, 0x07, 0x00,
    0x60, 0x20, 0x03, 0x00, 0x50, 0x20, 0x03, 0x00, 0x40, 0x20, 0x03, 0x00, 0x30, 0x20, 0x03, 0x00,
    0x20, 0x20, 0x03, 0x00, 0x10, 0x20, 0x03, 0x41, 0xb3, 0x01, 0xe0, 0xbe, 0x21, 0xa6, 0x20, 0x03,
    0x00, 0xa0, 0x20, 0x03, 0x00, 0x80, 0x20, 0x03, 0x00, 0x40, 0x20, 0x03, 0x00, 0x00, 0x20, 0x03,
    0x01, 0x80, 0xbd, 0x81, 0x1c, 0x01, 0x80, 0x3d, 0x20, 0x07, 0x22, 0x69, 0x00, 0x40, 0x20, 0x03,
    0x41, 0x0b, 0x00, 0xa0, 0x20, 0x07, 0x00, 0xc0, 0x20, 0x03, 0x00, 0xe0, 0x20, 0x03, 0x40, 0xfb,
    0x00, 0x10, 0x20, 0xa3, 0x00, 0x20, 0x20, 0x03, 0x00, 0x30, 0x20, 0x03, 0x40, 0xeb, 0x00, 0x50,
    0x20, 0x07, 0x00, 0x60, 0x20, 0x03, 0x00, 0x70, 0x20, 0x03, 0x40, 0xdb, 0x00, 0x88, 0x20, 0x07,
    0x00, 0x90, 0x20, 0x03, 0x00, 0x98, 0x20, 0x03, 0x40, 0xcb, 0x00, 0xa8, 0x20, 0x07, 0x00, 0xb0,
    0x20, 0x03, 0x00, 0xb8, 0x20, 0x03, 0x1b, 0x01, 0x00, 0x02, 0x00, 0x03, 0x00, 0x04, 0x00, 0x05,
    0x00, 0x06, 0x00, 0x07, 0x00, 0x08, 0x00, 0x09, 0x00, 0x0a, 0x00, 0x0b, 0x00, 0x0c, 0x00, 0x0d,
    0x00, 0x0e, 0x00, 0x23, 0x0c, 0xe0, 0x38, 0x1f, 0x40, 0x00, 0x01, 0x20, 0x41, 0x22, 0xd9, 0x20,
    0x03, 0x00, 0xf0, 0x20, 0x03, 0x40, 0x00, 0xe0, 0xa1, 0x0f, 0x13, 0xff, 0x00, 0x00, 0xff, 0x01,
    0xfe, 0xff, 0xfd, 0x00, 0xfc, 0x01, 0x00, 0xff, 0xff, 0x00, 0xfe, 0x01, 0xfd, 0xff, 0xfc, 0x21,
    0x13, 0x06, 0xff, 0xff, 0xfe, 0x00, 0xfd, 0x01, 0xfc, 0xe0, 0x37, 0x1d, 0x01, 0x01, 0xfe,
};

std::string Block(const unsigned char* bytes, std::size_t size) { return std::string(bytes, bytes + size); }
const std::string kXyziBlock = Block(kPclXyziBlock, sizeof(kPclXyziBlock));
const std::string kMixedBlock = Block(kPclMixedBlock, sizeof(kPclMixedBlock));

/// The file as PCL wrote it: header, block, zeros up to 4096 bytes.
std::string PaddedFile(const std::string& name, const std::string& header, const std::string& block) {
  return WriteFile(name, header, block + std::string(4096 - header.size() - block.size(), '\0'));
}

/// `block` with the uint32 at byte `at` replaced.
std::string WithSize(std::string block, std::size_t at, std::uint32_t value) {
  std::memcpy(&block[at], &value, sizeof(value));
  return block;
}

void CheckPoint(const PointXYZI& p, float x, float y, float z, float intensity) {
  CHECK(SameBits(p, PointXYZI{x, y, z, intensity}));
}

TEST_CASE("pcd binary_compressed: a file written by PCL reads as its ascii source, the NaN point dropped") {
  const std::string path = PaddedFile("pcl_xyzi.pcd", kPclXyziHeader, kXyziBlock);
  auto cloud = ReadPcd(path);
  REQUIRE(cloud.ok());
  CHECK(cloud->records_in_file == 5);
  CHECK(cloud->dropped_nonfinite == 1);
  REQUIRE(cloud->points.size() == 4);
  for (int i = 0; i < 3; ++i) CheckPoint(cloud->points[i], 1.5f, -2.25f, 3.0f, 0.5f);
  CheckPoint(cloud->points[3], 0.1f, 100.125f, -7.0f, 255.0f);
  CHECK(cloud->robot_ids.empty());

  // Without PCL's zero padding, the block alone reads the same.
  const std::string unpadded = WriteFile("pcl_xyzi_unpadded.pcd", kPclXyziHeader, kXyziBlock);
  auto same = ReadPcd(unpadded);
  REQUIRE(same.ok());
  CHECK(same->points.size() == 4);
}

TEST_CASE("pcd binary_compressed: PCL's column order with mixed types, a COUNT 2 field and fields before x") {
  const std::string path = PaddedFile("pcl_mixed.pcd", kPclMixedHeader, kMixedBlock);
  auto cloud = ReadPcd(path);
  REQUIRE(cloud.ok());
  CHECK(cloud->records_in_file == 48);
  CHECK(cloud->dropped_nonfinite == 0);
  REQUIRE(cloud->points.size() == 48);
  for (int i = 0; i < 48; ++i) {
    CAPTURE(i);
    CheckPoint(cloud->points[i], static_cast<float>(i % 8) * 0.5f - 2.0f, static_cast<float>(i / 8) * 0.25f,
               -1.5f + 0.0625f * static_cast<float>(i), static_cast<float>(i % 4) * 10.0f);
  }
}

TEST_CASE("pcd binary_compressed: a truncated block is truncated data naming the file") {
  const std::string cut = WriteFile("pcl_cut.pcd", kPclXyziHeader, kXyziBlock.substr(0, kXyziBlock.size() - 10));
  auto cloud = ReadPcd(cut);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, cut,
             {"truncated: DATA binary_compressed announces 57 compressed bytes, the file has 47 after the size fields"});

  // Sizes consistent with the shorter file: the LZF stream itself ends early.
  const std::string short_stream =
      WriteFile("pcl_short_stream.pcd", kPclXyziHeader, WithSize(kXyziBlock.substr(0, 8 + 40), 0, 40));
  cloud = ReadPcd(short_stream);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, short_stream, {"DATA binary_compressed: LZF data", "truncated"});

  const std::string no_sizes = WriteFile("pcl_no_sizes.pcd", kPclXyziHeader, kXyziBlock.substr(0, 5));
  cloud = ReadPcd(no_sizes);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, no_sizes, {"needs 8 bytes of sizes", "the file has 5"});
}

TEST_CASE("pcd binary_compressed: lying sizes are refused before anything is allocated") {
  const auto start = std::chrono::steady_clock::now();
  const std::string other = WriteFile("pcl_lying.pcd", kPclXyziHeader, WithSize(kXyziBlock, 4, 160));
  auto cloud = ReadPcd(other);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, other,
             {"announces 160 uncompressed bytes, but POINTS 5 x 16 record bytes = 80"});

  // A header and size fields that agree, but 57 LZF bytes cannot become 16 MB.
  std::string header = kPclXyziHeader;
  header.replace(header.find("WIDTH 5"), 7, "WIDTH 1000000");
  header.replace(header.find("POINTS 5"), 8, "POINTS 1000000");
  const std::string expand = WriteFile("pcl_expand.pcd", header, WithSize(kXyziBlock, 4, 16000000));
  cloud = ReadPcd(expand);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, expand,
             {"announces 16000000 uncompressed bytes from 57 compressed bytes; LZF expands at most 88-fold"});

  header = kPclXyziHeader;
  header.replace(header.find("WIDTH 5"), 7, "WIDTH 1000000000000");
  header.replace(header.find("POINTS 5"), 8, "POINTS 1000000000000");
  const std::string huge = WriteFile("pcl_huge.pcd", header, kXyziBlock);
  cloud = ReadPcd(huge);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, huge,
             {"POINTS 1000000000000 x 16 record bytes = 16000000000000 bytes: more than DATA binary_compressed can "
              "hold"});
  CHECK(std::chrono::steady_clock::now() - start < std::chrono::seconds(5));
}

TEST_CASE("pcd binary_compressed: a back reference before the start of the data is corrupt data") {
  std::string block = kXyziBlock;
  block[8] = '\x20';  // the first token: a back reference of 3 bytes from distance 6, with nothing written yet
  block[9] = '\x05';
  const std::string path = WriteFile("pcl_backref.pcd", kPclXyziHeader, block);
  auto cloud = ReadPcd(path);
  REQUIRE_FALSE(cloud.ok());
  CheckError(cloud.status(), StatusCode::kDataLoss, path,
             {"LZF data at byte 0: a back reference 6 bytes behind output byte 0 points before the start"});
}

TEST_CASE("pcd binary_compressed: an empty cloud with empty sizes reads as no points") {
  std::string header = kPclXyziHeader;
  header.replace(header.find("WIDTH 5"), 7, "WIDTH 0");
  header.replace(header.find("POINTS 5"), 8, "POINTS 0");
  const std::string path = WriteFile("pcl_empty.pcd", header, std::string(8, '\0'));
  auto cloud = ReadPcd(path);
  REQUIRE(cloud.ok());
  CHECK(cloud->points.empty());
  CHECK(cloud->records_in_file == 0);
}

}  // namespace pcd_compressed_test
}  // namespace commerge::platform
