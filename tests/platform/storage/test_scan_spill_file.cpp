// SPDX-License-Identifier: BSD-3-Clause
// File-backed spill sink: round trip, errors naming the path, and a ScanStore spilling into it.
#include <doctest/doctest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "core/cloud/scan_codec.hpp"
#include "core/slam/scan_store.hpp"
#include "platform/storage/scan_spill_file.hpp"
#include "tests/support/scan_chunks.hpp"
#include "tests/support/strings.hpp"
#include "tests/support/test_data.hpp"

namespace commerge::platform {
namespace {

namespace fs = std::filesystem;
using test::Contains;

std::string FreshDir(const std::string& name) {
  const fs::path dir = fs::path(test::ScratchDir()) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

std::vector<std::uint8_t> MakeScan(std::uint32_t keyframe, std::size_t n) {
  std::vector<PointXYZI> cloud(n);
  for (std::size_t i = 0; i < n; ++i) {
    cloud[i] = {static_cast<float>(keyframe) * 0.5f, static_cast<float>(i) * 0.01f, -1.25f, 0.0f};
  }
  return test::EncodeForTest(cloud);
}

std::unique_ptr<ScanSpillFile> OpenOrFail(const std::string& dir, const ScanSpillFileOptions& options = {}) {
  Result<std::unique_ptr<ScanSpillFile>> sink = ScanSpillFile::Open(dir, options);
  REQUIRE_MESSAGE(sink.ok(), sink.status().ToString());
  return std::move(sink.value());
}

}  // namespace

TEST_CASE("scan_spill_file: spilled scans load back byte for byte, the file holds exactly the records") {
  const std::string dir = FreshDir("spill_roundtrip");
  std::unique_ptr<ScanSpillFile> sink = OpenOrFail(dir);
  CHECK(sink->path() == dir + "/scan_spill.bin");
  const std::vector<std::uint32_t> keyframes = {3, 4, 9, 100};
  const std::vector<std::size_t> sizes = {0, 1, 4000, 17};
  std::uint64_t expected_bytes = 0;
  for (std::size_t i = 0; i < keyframes.size(); ++i) {
    const std::vector<std::uint8_t> scan = MakeScan(keyframes[i], sizes[i]);
    REQUIRE(sink->Spill(keyframes[i], Span<const std::uint8_t>(scan)).ok());
    expected_bytes += ScanSpillFile::kRecordHeaderBytes + scan.size();
  }
  CHECK(sink->num_records() == 4);
  CHECK(sink->file_bytes() == expected_bytes);
  CHECK(fs::file_size(sink->path()) == expected_bytes);  // flushed: visible to another reader now
  std::vector<std::uint8_t> loaded;
  for (std::size_t i = keyframes.size(); i-- > 0;) {  // any order
    REQUIRE(sink->Load(keyframes[i], &loaded).ok());
    CHECK(loaded == MakeScan(keyframes[i], sizes[i]));
  }
  // Spills after loads still append at the end.
  const std::vector<std::uint8_t> later = MakeScan(101, 5);
  REQUIRE(sink->Spill(101, Span<const std::uint8_t>(later)).ok());
  REQUIRE(sink->Load(101, &loaded).ok());
  CHECK(loaded == later);
  REQUIRE(sink->Load(9, &loaded).ok());
  CHECK(loaded == MakeScan(9, 4000));
}

TEST_CASE("scan_spill_file: a missing keyframe is NotFound and a non-increasing one is refused") {
  const std::string dir = FreshDir("spill_missing");
  std::unique_ptr<ScanSpillFile> sink = OpenOrFail(dir);
  std::vector<std::uint8_t> loaded = {1, 2, 3};
  Status s = sink->Load(7, &loaded);
  CHECK(s.code() == StatusCode::kNotFound);
  CHECK(Contains(s.message(), sink->path()));
  CHECK(Contains(s.message(), "keyframe 7 was never spilled"));
  CHECK(loaded.empty());
  const std::vector<std::uint8_t> scan = MakeScan(7, 3);
  REQUIRE(sink->Spill(7, Span<const std::uint8_t>(scan)).ok());
  s = sink->Spill(7, Span<const std::uint8_t>(scan));
  CHECK(s.code() == StatusCode::kInvalidArgument);
  CHECK(Contains(s.message(), "keyframe indices must increase"));
  CHECK(sink->Load(6, &loaded).code() == StatusCode::kNotFound);
  CHECK(sink->Load(8, &loaded).code() == StatusCode::kNotFound);
}

TEST_CASE("scan_spill_file: a missing or read-only directory gives an error naming the path") {
  const std::string missing = FreshDir("spill_parent") + "/does/not/exist";
  Result<std::unique_ptr<ScanSpillFile>> r = ScanSpillFile::Open(missing);
  REQUIRE_FALSE(r.ok());
  CHECK(r.status().code() == StatusCode::kNotFound);
  CHECK(Contains(r.status().message(), missing + "/scan_spill.bin: cannot create the scan spill file"));

  // Permission bits do not stop root, so as root use sysfs, where even root cannot create files.
  std::string read_only;
  if (geteuid() != 0) {
    read_only = FreshDir("spill_read_only");
    REQUIRE(chmod(read_only.c_str(), 0555) == 0);
  } else if (fs::is_directory("/sys/kernel")) {
    read_only = "/sys/kernel";
  }
  if (read_only.empty()) {
    MESSAGE("read-only directory case not exercised: running as root without /sys");
  } else {
    r = ScanSpillFile::Open(read_only);
    REQUIRE_FALSE(r.ok());
    CHECK(r.status().code() == StatusCode::kIoError);
    CHECK(Contains(r.status().message(), read_only + "/scan_spill.bin: cannot create the scan spill file"));
    if (geteuid() != 0) chmod(read_only.c_str(), 0755);
  }
  CHECK_FALSE(ScanSpillFile::Open(FreshDir("spill_bad_name"), {"a/b", 0, 0}).ok());
}

TEST_CASE("scan_spill_file: max_file_bytes bounds the file and a record changed on disk is detected") {
  const std::string dir = FreshDir("spill_limit");
  ScanSpillFileOptions options;
  options.max_file_bytes = 2 * (ScanSpillFile::kRecordHeaderBytes + EncodedScanBytes(10));
  std::unique_ptr<ScanSpillFile> sink = OpenOrFail(dir, options);
  const std::vector<std::uint8_t> scan = MakeScan(1, 10);
  REQUIRE(sink->Spill(1, Span<const std::uint8_t>(scan)).ok());
  REQUIRE(sink->Spill(2, Span<const std::uint8_t>(scan)).ok());
  const Status full = sink->Spill(3, Span<const std::uint8_t>(scan));
  CHECK(full.code() == StatusCode::kResourceExhausted);
  CHECK(Contains(full.message(), sink->path()));
  CHECK(Contains(full.message(), "beyond its limit of 168 B"));
  CHECK(sink->num_records() == 2);

  // Overwrite the keyframe field of record 2 from outside.
  {
    std::FILE* f = std::fopen(sink->path().c_str(), "r+b");
    REQUIRE(f != nullptr);
    REQUIRE(std::fseek(f, static_cast<long>(ScanSpillFile::kRecordHeaderBytes + scan.size() + 4), SEEK_SET) == 0);
    const unsigned char other[1] = {9};
    REQUIRE(std::fwrite(other, 1, 1, f) == 1);
    REQUIRE(std::fclose(f) == 0);
  }
  std::vector<std::uint8_t> loaded;
  const Status s = sink->Load(2, &loaded);
  CHECK(s.code() == StatusCode::kDataLoss);
  CHECK(Contains(s.message(), "is not the one of keyframe 2"));
  CHECK(sink->Load(1, &loaded).ok());
}

TEST_CASE("scan_store + scan_spill_file: ScanStore spilling into a ScanSpillFile returns every scan ever stored") {
  const std::string dir = FreshDir("spill_store");
  std::unique_ptr<ScanSpillFile> sink = OpenOrFail(dir);
  ScanStoreParams params;
  params.capacity_bytes = 8 * 1024;
  params.max_scans = 100;
  params.policy = ScanStorePolicy::kSpillOldest;
  Result<std::unique_ptr<ScanStore>> created = ScanStore::Create(params, sink.get());
  REQUIRE(created.ok());
  ScanStore& store = **created;
  for (std::uint32_t k = 1; k <= 200; ++k) {
    const std::vector<std::uint8_t> scan = MakeScan(k, 50 + (k * 37) % 300);
    const Result<ScanPutInfo> r = store.Put(k, Span<const std::uint8_t>(scan));
    REQUIRE_MESSAGE(r.ok(), r.status().ToString());
    REQUIRE(r->spill_status.ok());
  }
  const ScanStoreStats s = store.stats();
  CHECK(s.num_spilled == sink->num_records());
  CHECK(s.num_spilled + s.num_scans == 200);
  CHECK(s.num_evicted == 0);
  std::vector<std::uint8_t> copy;
  std::vector<PointXYZI> points;
  for (std::uint32_t k = 1; k <= 200; ++k) {
    REQUIRE(store.CopyEncoded(k, &copy).ok());
    CHECK(copy == MakeScan(k, 50 + (k * 37) % 300));
    REQUIRE(store.GetPoints(k, &points, &copy).ok());
    CHECK(points.size() == 50 + (k * 37) % 300);
  }
}

}  // namespace commerge::platform
