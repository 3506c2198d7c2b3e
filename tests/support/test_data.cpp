// SPDX-License-Identifier: BSD-3-Clause
#include "tests/support/test_data.hpp"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <filesystem>
#include <random>
#include <string>
#include <system_error>

#include "tests/support/test_skip.hpp"

namespace fs = std::filesystem;

namespace commerge::test {

std::string SharedDataDir() {
  if (const char* env = std::getenv("COMMERGE_SHARED_DATA"); env && *env) return env;
  return CM_SHARED_DATA_DIR;
}

std::string SharedDataPathOrSkip(const std::string& relative, const char* file, int line) {
  const fs::path p = fs::path(SharedDataDir()) / relative;
  RequireNoAssertionYet("shared data " + p.string(), file, line);
  std::error_code ec;
  if (fs::exists(p, ec)) return p.string();
  SkipTestCase("this test needs " + p.string() +
                   " (licensed test data, never in the repository; set COMMERGE_SHARED_DATA to its location)",
               file, line);
  return {};
}

std::string ReadTextFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::fprintf(stderr, "test_data: cannot open %s\n", path.c_str());
    std::abort();
  }
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

namespace {
struct Scratch {
  fs::path dir;
  Scratch() {
    const char* tmp = std::getenv("TMPDIR");
    std::random_device rd;
    const fs::path base = (tmp && *tmp) ? fs::path(tmp) : fs::path("/tmp");
    for (int attempt = 0; attempt < 100; ++attempt) {
      fs::path candidate = base / ("commerge-test-" + std::to_string(rd()));
      std::error_code ec;
      if (fs::create_directory(candidate, ec)) {
        dir = candidate;
        return;
      }
    }
    std::fprintf(stderr, "test_data: cannot create a scratch directory under %s\n", base.string().c_str());
    std::abort();
  }
  ~Scratch() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};
}  // namespace

std::string ScratchDir() {
  static Scratch scratch;
  return scratch.dir.string();
}

std::string ScratchFile(const std::string& name) { return ScratchDir() + "/" + name; }

}  // namespace commerge::test
