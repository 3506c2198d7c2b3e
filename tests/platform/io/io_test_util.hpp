// SPDX-License-Identifier: BSD-3-Clause
// Helpers shared by the file-format tests: scratch files written byte by byte (independently of our
// writers), bit-exact point comparison and error-message checks.
#pragma once

#include <doctest/doctest.h>

#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/common/status.hpp"
#include "tests/support/test_data.hpp"

namespace commerge::platform {

using test::ScratchFile;

/// Header text followed by raw bytes, written with fwrite.
inline std::string WriteFile(const std::string& name, const std::string& header, const std::string& bytes = {}) {
  const std::string path = ScratchFile(name);
  std::FILE* f = std::fopen(path.c_str(), "wb");
  REQUIRE(f != nullptr);
  const std::string all = header + bytes;
  REQUIRE(std::fwrite(all.data(), 1, all.size(), f) == all.size());
  REQUIRE(std::fclose(f) == 0);
  return path;
}

/// Little-endian record bytes, built field by field.
struct Bytes {
  std::string data;
  template <class T>
  Bytes& Put(T value) {
    data.append(reinterpret_cast<const char*>(&value), sizeof(T));
    return *this;
  }
};

inline bool SameBits(const PointXYZI& a, const PointXYZI& b) { return std::memcmp(&a, &b, sizeof(PointXYZI)) == 0; }

/// The error has `code`, its message starts with the path and contains every part of `parts`.
inline void CheckError(const Status& status, StatusCode code, const std::string& path,
                       const std::vector<std::string>& parts) {
  CHECK(status.code() == code);
  CHECK(status.message().rfind(path, 0) == 0);
  for (const std::string& part : parts) {
    INFO("message: ", status.message(), " expected to contain: ", part);
    CHECK(status.message().find(part) != std::string::npos);
  }
}

}  // namespace commerge::platform
