// SPDX-License-Identifier: BSD-3-Clause
// PNG writer and RgbImage: files decoded by an independent reader (tests/support/png_reader.hpp: chunk walk,
// CRC-32, zlib uncompress, all five PNG filters undone), error paths, and clipping of every drawing primitive.
#include <doctest/doctest.h>

#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

#include "core/common/float_limits.hpp"
#include "platform/report/png_writer.hpp"
#include "platform/report/raster_image.hpp"
#include "tests/support/png_reader.hpp"
#include "tests/support/test_data.hpp"

namespace commerge::platform {
namespace {

constexpr Rgb kWhite{255, 255, 255};
constexpr Rgb kRed{255, 0, 0};

using test::ScratchFile;

bool Exists(const std::string& path) {
  struct stat st {};
  return ::lstat(path.c_str(), &st) == 0;
}

using Decoded = test::DecodedPng;

/// The file decoded by the independent reader (tests/support/png_reader.hpp); a file it refuses fails the test.
Decoded DecodePng(const std::string& path) {
  Decoded d = test::DecodePngFile(path);
  REQUIRE_MESSAGE(d.ok, d.error);
  return d;
}

RgbImage MakeImage(int w, int h, Rgb background = kWhite) {
  auto image = RgbImage::Create(w, h, background);
  REQUIRE(image.ok());
  return std::move(*image);
}

RgbImage RandomImage(int w, int h, unsigned seed) {
  RgbImage image = MakeImage(w, h);
  std::mt19937 rng(seed);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      image.SetPixel(x, y, Rgb{static_cast<std::uint8_t>(rng()), static_cast<std::uint8_t>(rng()),
                               static_cast<std::uint8_t>(rng())});
    }
  }
  return image;
}

/// Smooth ramps (where Sub, Up, Average and Paeth win) with a few sharp edges.
RgbImage GradientImage(int w, int h) {
  RgbImage image = MakeImage(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      image.SetPixel(x, y, Rgb{static_cast<std::uint8_t>(x * 3 + y), static_cast<std::uint8_t>(y * 5),
                               static_cast<std::uint8_t>((x * y) / 7 + (x % 17 == 0 ? 90 : 0))});
    }
  }
  return image;
}

void CheckRoundTrip(const RgbImage& image, const std::string& name) {
  CAPTURE(name);
  const std::string path = ScratchFile(name);
  const Status written = WritePng(path, image);
  REQUIRE_MESSAGE(written.ok(), written.ToString());
  CHECK_FALSE(Exists(path + ".tmp"));
  const Decoded decoded = DecodePng(path);
  CHECK(decoded.width == image.width());
  CHECK(decoded.height == image.height());
  REQUIRE(decoded.rgb.size() == image.rgb().size());
  std::size_t mismatches = 0;
  for (std::size_t i = 0; i < decoded.rgb.size(); ++i) mismatches += decoded.rgb[i] != image.rgb()[i];
  CHECK(mismatches == 0);
}

/// The pixels as a snapshot, for "nothing changed" checks.
std::vector<std::uint8_t> Snapshot(const RgbImage& image) { return image.rgb(); }

/// Set of (x, y) pixels whose colour is `colour`.
std::set<std::pair<int, int>> PixelsOf(const RgbImage& image, Rgb colour) {
  std::set<std::pair<int, int>> out;
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      if (image.At(x, y) == colour) out.insert({x, y});
    }
  }
  return out;
}

TEST_CASE("PNG files decode with an independent reader to exactly the written pixels") {
  CheckRoundTrip(MakeImage(1, 1, Rgb{12, 34, 56}), "one.png");
  CheckRoundTrip(RandomImage(7, 5, 1), "small_random.png");
  CheckRoundTrip(GradientImage(120, 45), "gradient.png");
  CheckRoundTrip(MakeImage(300, 2, Rgb{0, 128, 255}), "flat.png");
}

TEST_CASE("PNG writer splits large IDAT data into several chunks and uses several filters") {
  const RgbImage noise = RandomImage(160, 160, 7);  // 76.8 kB of incompressible pixels
  CheckRoundTrip(noise, "noise.png");
  const Decoded decoded = DecodePng(ScratchFile("noise.png"));
  CHECK(decoded.idat_chunks >= 2);
  const RgbImage ramp = GradientImage(64, 64);
  CheckRoundTrip(ramp, "ramp.png");
  const Decoded ramp_decoded = DecodePng(ScratchFile("ramp.png"));
  CHECK(ramp_decoded.filters_used.size() >= 2);
  CHECK(*ramp_decoded.filters_used.rbegin() > 0);  // not only filter 0
}

TEST_CASE("PNG writer replaces an existing file") {
  const std::string path = ScratchFile("replace.png");
  std::FILE* f = std::fopen(path.c_str(), "wb");
  REQUIRE(f != nullptr);
  std::fputs("not a png, and longer than nothing", f);
  REQUIRE(std::fclose(f) == 0);
  CheckRoundTrip(GradientImage(9, 9), "replace.png");
}

TEST_CASE("PNG writer names the path when the directory does not exist and leaves no file") {
  const std::string path = ScratchFile("no_such_dir/picture.png");
  const Status s = WritePng(path, MakeImage(4, 4));
  REQUIRE_FALSE(s.ok());
  CHECK(s.code() == StatusCode::kIoError);
  CHECK(s.message().find(path) != std::string::npos);
  CHECK(s.message().find("No such file") != std::string::npos);
  CHECK_FALSE(Exists(path));
  CHECK_FALSE(Exists(path + ".tmp"));
}

TEST_CASE("PNG writer reports a rename onto a directory and removes the temporary file") {
  const std::string path = ScratchFile("is_a_dir.png");
  REQUIRE(::mkdir(path.c_str(), 0755) == 0);
  const Status s = WritePng(path, MakeImage(4, 4));
  REQUIRE_FALSE(s.ok());
  CHECK(s.code() == StatusCode::kIoError);
  CHECK(s.message().find(path) != std::string::npos);
  CHECK_FALSE(Exists(path + ".tmp"));
}

TEST_CASE("PNG writer reports a full disk and removes the temporary file") {
  if (::access("/dev/full", W_OK) != 0) {
    MESSAGE("/dev/full is not writable here; full-disk case not run");
    return;
  }
  const std::string path = ScratchFile("full.png");
  REQUIRE(::symlink("/dev/full", (path + ".tmp").c_str()) == 0);  // the writer's temporary file hits ENOSPC
  const Status s = WritePng(path, RandomImage(40, 40, 3));
  REQUIRE_FALSE(s.ok());
  CHECK(s.code() == StatusCode::kIoError);
  CHECK(s.message().find(path) != std::string::npos);
  CHECK(s.message().find("No space left") != std::string::npos);
  CHECK_FALSE(Exists(path));
  CHECK_FALSE(Exists(path + ".tmp"));
}

TEST_CASE("PNG writer refuses an empty image") {
  const std::string path = ScratchFile("empty.png");
  const Status s = WritePng(path, RgbImage());
  CHECK(s.code() == StatusCode::kInvalidArgument);
  CHECK(s.message().find(path) != std::string::npos);
  CHECK_FALSE(Exists(path));
}

TEST_CASE("RgbImage refuses sizes outside 1..8192 per side and names the size") {
  const int bad[][2] = {{0, 10}, {10, 0}, {-3, 5}, {8193, 1}, {1, 8193}, {INT_MIN, INT_MAX}};
  for (const auto& size : bad) {
    CAPTURE(size[0]);
    CAPTURE(size[1]);
    const auto image = RgbImage::Create(size[0], size[1], kWhite);
    REQUIRE_FALSE(image.ok());
    CHECK(image.status().code() == StatusCode::kInvalidArgument);
    CHECK(image.status().message().find(std::to_string(size[0]) + " x " + std::to_string(size[1])) !=
          std::string::npos);
  }
  const auto thin = RgbImage::Create(8192, 1, Rgb{1, 2, 3});
  REQUIRE(thin.ok());
  CHECK(thin->width() == 8192);
  CHECK(thin->rgb().size() == 8192u * 3u);
  CHECK(thin->At(8191, 0) == Rgb{1, 2, 3});
}

TEST_CASE("RgbImage drawing entirely outside or with non-finite coordinates changes nothing") {
  RgbImage image = MakeImage(40, 30);
  const std::vector<std::uint8_t> before = Snapshot(image);
  image.SetPixel(-1, 0, kRed);
  image.SetPixel(40, 0, kRed);
  image.SetPixel(0, 30, kRed);
  image.SetPixel(INT_MIN, INT_MAX, kRed);
  image.FillRect(INT_MIN, INT_MIN, -1, -1, kRed);
  image.FillRect(40, 0, INT_MAX, INT_MAX, kRed);
  image.DrawRect(INT_MIN, INT_MIN, INT_MAX, INT_MAX, kRed, 3);  // a ring far outside the image
  image.DrawRect(-10, -10, 50, 40, kRed, 5);                    // a ring just outside
  image.DrawRect(0, 0, 39, 29, kRed, 0);                        // zero thickness
  for (int t = 1; t <= 3; ++t) {
    image.DrawLine(-1e30f, -1e30f, -1e30f, 1e30f, kRed, t);
    image.DrawLine(-5.0f, -5.0f, 100.0f, -5.0f, kRed, t);
    image.DrawLine(45.0f, -3.0f, 45.0f, 100.0f, kRed, t);
    image.DrawLine(kFloatNaN, 5.0f, 10.0f, 10.0f, kRed, t);
    image.DrawLine(5.0f, 5.0f, kFloatInf, 10.0f, kRed, t);
    image.DrawLine(-kFloatInf, -kFloatInf, kFloatInf, kFloatInf, kRed, t);
    image.DrawLine(-100.0f, 200.0f, 200.0f, -100.0f, kRed, t);  // passes the corner at distance > 20 px
  }
  image.FillDisc(-1000.0f, 15.0f, 10.0f, kRed);
  image.FillDisc(20.0f, 15.0f, kFloatNaN, kRed);
  image.FillDisc(kFloatNaN, 15.0f, 5.0f, kRed);
  image.FillDisc(20.0f, kFloatInf, 5.0f, kRed);
  image.FillDisc(20.0f, 15.0f, kFloatInf, kRed);
  image.FillDisc(20.0f, 15.0f, -1.0f, kRed);
  image.FillDisc(-1e31f, 0.0f, 1e30f, kRed);
  image.DrawText(INT_MIN, INT_MIN, "text", kRed, 3);
  image.DrawText(INT_MAX - 3, 0, "text", kRed, 64);
  image.DrawText(-1000, 10, "a long line that ends before the image starts", kRed, 2);
  image.DrawText(0, 0, "hidden", kRed, 0);
  image.DrawText(0, 0, "hidden", kRed, 65);
  image.DrawTextUp(INT_MAX, INT_MAX, "up", kRed, 2);
  image.DrawTextUp(5, INT_MIN, "up", kRed, 2);
  image.DrawTextUp(5, -200, "up up up", kRed, 2);
  CHECK(Snapshot(image) == before);

  RgbImage empty;
  empty.FillRect(0, 0, 10, 10, kRed);
  empty.DrawLine(0.0f, 0.0f, 5.0f, 5.0f, kRed, 2);
  empty.FillDisc(1.0f, 1.0f, 3.0f, kRed);
  empty.DrawText(0, 0, "x", kRed, 1);
  CHECK(empty.rgb().empty());
  CHECK(empty.At(0, 0) == Rgb{});
}

TEST_CASE("RgbImage primitives crossing the border draw exactly their pixels inside") {
  const int w = 30, h = 20;
  SUBCASE("rectangles") {
    RgbImage image = MakeImage(w, h);
    image.FillRect(3, 2, -5, -5, kRed);  // corners in any order
    image.DrawRect(20, 10, 40, 40, Rgb{0, 0, 255}, 2);
    std::set<std::pair<int, int>> fill, ring;
    for (int y = 0; y <= 2; ++y)
      for (int x = 0; x <= 3; ++x) fill.insert({x, y});
    for (int y = 10; y < h; ++y)
      for (int x = 20; x < w; ++x)
        if (x <= 21 || y <= 11) ring.insert({x, y});
    CHECK(PixelsOf(image, kRed) == fill);
    CHECK(PixelsOf(image, Rgb{0, 0, 255}) == ring);
  }
  SUBCASE("lines") {
    RgbImage image = MakeImage(w, h);
    image.DrawLine(-100.0f, 10.0f, 100.0f, 10.0f, kRed, 1);
    std::set<std::pair<int, int>> row;
    for (int x = 0; x < w; ++x) row.insert({x, 10});
    CHECK(PixelsOf(image, kRed) == row);

    RgbImage thick = MakeImage(w, h);
    thick.DrawLine(5.0f, -1e9f, 5.0f, 1e9f, kRed, 3);
    std::set<std::pair<int, int>> band;
    for (int y = 0; y < h; ++y)
      for (int x = 4; x <= 6; ++x) band.insert({x, y});
    CHECK(PixelsOf(thick, kRed) == band);

    RgbImage diagonal = MakeImage(w, h);
    diagonal.DrawLine(-10.0f, -10.0f, 100.0f, 100.0f, kRed, 1);
    std::set<std::pair<int, int>> diag;
    for (int i = 0; i < h; ++i) diag.insert({i, i});
    CHECK(PixelsOf(diagonal, kRed) == diag);

    RgbImage steep = MakeImage(w, h);  // endpoints rounded; one pixel per row of a steep segment
    steep.DrawLine(2.4f, 1.6f, 7.0f, 17.0f, kRed, 1);
    const auto pixels = PixelsOf(steep, kRed);
    CHECK(pixels.size() == 16);
    CHECK(pixels.count({2, 2}) == 1);
    CHECK(pixels.count({7, 17}) == 1);
  }
  SUBCASE("discs") {
    RgbImage image = MakeImage(w, h);
    image.FillDisc(0.0f, 0.0f, 5.5f, kRed);
    std::set<std::pair<int, int>> expected;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if (x * x + y * y <= 30) expected.insert({x, y});  // 5.5^2 = 30.25
    CHECK(PixelsOf(image, kRed) == expected);

    RgbImage huge = MakeImage(w, h);
    huge.FillDisc(15.0f, 10.0f, 1e20f, kRed);
    CHECK(PixelsOf(huge, kRed).size() == static_cast<std::size_t>(w * h));

    RgbImage dot = MakeImage(w, h);
    dot.FillDisc(29.2f, 19.4f, 0.0f, kRed);  // no pixel centre at distance 0
    CHECK(PixelsOf(dot, kRed).empty());
    dot.FillDisc(29.0f, 19.0f, 0.0f, kRed);
    CHECK(PixelsOf(dot, kRed) == std::set<std::pair<int, int>>{{29, 19}});
  }
  SUBCASE("text cut by the border") {
    RgbImage full = MakeImage(w + 20, h + 20);
    full.DrawText(10, 5, "Ag", kRed, 2);
    RgbImage cut = MakeImage(w, h);
    cut.DrawText(10 - 13, 5 - 9, "Ag", kRed, 2);  // same text moved up-left, partly outside
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        CAPTURE(x);
        CAPTURE(y);
        CHECK((cut.At(x, y) == kRed) == (full.At(x + 13, y + 9) == kRed));
      }
    }
  }
}

/// The 5 x 7 bit pattern of one character drawn at scale 1 (row-major, 35 entries).
std::vector<bool> GlyphBits(char c) {
  RgbImage image = MakeImage(7, 9);
  image.DrawText(1, 1, std::string(1, c), kRed, 1);
  std::vector<bool> bits;
  for (int y = 0; y < 9; ++y) {
    for (int x = 0; x < 7; ++x) {
      const bool on = image.At(x, y) == kRed;
      if (x >= 1 && x <= 5 && y >= 1 && y <= 7) {
        bits.push_back(on);
      } else {
        REQUIRE_FALSE(on);  // nothing outside the 5 x 7 cell
      }
    }
  }
  return bits;
}

TEST_CASE("RgbImage font: every printable glyph is drawn and distinct, others are boxes") {
  std::set<std::vector<bool>> seen;
  for (int c = 33; c <= 126; ++c) {
    CAPTURE(c);
    const std::vector<bool> bits = GlyphBits(static_cast<char>(c));
    int on = 0;
    for (const bool b : bits) on += b;
    CHECK(on >= 2);
    CHECK(seen.insert(bits).second);
  }
  for (const bool b : GlyphBits(' ')) CHECK_FALSE(b);
  for (const char unknown : {'\x01', '\n', '\x7f', static_cast<char>(0xC3)}) {
    const std::vector<bool> box = GlyphBits(unknown);
    for (int y = 0; y < 7; ++y) {
      for (int x = 0; x < 5; ++x) {
        const bool edge = x == 0 || x == 4 || y == 0 || y == 6;
        CHECK(box[static_cast<std::size_t>(y * 5 + x)] == edge);
      }
    }
  }
  CHECK(RgbImage::TextWidth("", 2) == 0);
  CHECK(RgbImage::TextWidth("A", 1) == 5);
  CHECK(RgbImage::TextWidth("AB", 1) == 11);
  CHECK(RgbImage::TextWidth("AB", 3) == 33);
  CHECK(RgbImage::TextHeight(2) == 14);
}

TEST_CASE("RgbImage text scales by blocks and DrawTextUp is the text turned counter-clockwise") {
  const std::string text = "R7q";
  const int tw = RgbImage::TextWidth(text, 1), th = RgbImage::TextHeight(1);
  RgbImage one = MakeImage(tw, th);
  one.DrawText(0, 0, text, kRed, 1);
  RgbImage three = MakeImage(3 * tw + 3, 3 * th);
  three.DrawText(0, 0, text, kRed, 3);
  for (int y = 0; y < 3 * th; ++y)
    for (int x = 0; x < 3 * tw; ++x) CHECK((three.At(x, y) == kRed) == (one.At(x / 3, y / 3) == kRed));
  RgbImage up = MakeImage(th + 4, tw + 4);
  up.DrawTextUp(2, 2, text, kRed, 1);
  for (int y = 0; y < up.height(); ++y) {
    for (int x = 0; x < up.width(); ++x) {
      // Rotated pixel (x, y) shows unrotated (gx, gy) = (tw - 1 - (y - 2), x - 2).
      const int gx = tw - 1 - (y - 2), gy = x - 2;
      const bool expected = gx >= 0 && gx < tw && gy >= 0 && gy < th && one.At(gx, gy) == kRed;
      CHECK((up.At(x, y) == kRed) == expected);
    }
  }
}

TEST_CASE("RobotColour gives 8 clearly distinct colours and cycles") {
  for (int i = 0; i < 8; ++i) {
    for (int j = i + 1; j < 8; ++j) {
      const Rgb a = RobotColour(i), b = RobotColour(j);
      const int distance = std::abs(a.r - b.r) + std::abs(a.g - b.g) + std::abs(a.b - b.b);
      CAPTURE(i);
      CAPTURE(j);
      CHECK(distance >= 60);
    }
    CHECK(RobotColour(i) != kWhite);
    CHECK(RobotColour(i + 8) == RobotColour(i));
    CHECK(RobotColour(i - 8) == RobotColour(i));
  }
  CHECK(RobotColour(-1) == RobotColour(7));
  CHECK(RobotColour(INT_MIN) == RobotColour(0));
}

}  // namespace
}  // namespace commerge::platform
