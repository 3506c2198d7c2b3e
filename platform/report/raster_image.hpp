// SPDX-License-Identifier: BSD-3-Clause
// An 8-bit RGB raster for the report pictures, with clipped drawing primitives and a 5x7 bitmap font.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/common/status.hpp"

namespace commerge::platform {

struct Rgb {
  std::uint8_t r = 0;
  std::uint8_t g = 0;
  std::uint8_t b = 0;
};
inline bool operator==(const Rgb& a, const Rgb& b) noexcept { return a.r == b.r && a.g == b.g && a.b == b.b; }
inline bool operator!=(const Rgb& a, const Rgb& b) noexcept { return !(a == b); }

/// One of 8 clearly distinct colours per robot (blue, orange, green, red, purple, brown, pink, cyan);
/// indices cycle after 8 (negative indices too: -1 is the 8th colour).
Rgb RobotColour(int robot_index) noexcept;

/// Width x height pixels, 3 bytes (r, g, b) per pixel, row-major, origin at the top-left corner.
/// Pixel (x, y) has its centre at the integer coordinates (x, y). Every drawing call clips to the image:
/// any coordinates (huge, negative, NaN, infinite) are safe; non-finite ones draw nothing.
class RgbImage {
 public:
  static constexpr int kMaxSide = 8192;
  /// Glyph cell of the built-in font at scale 1: 5 x 7 pixels, advance 6 pixels.
  static constexpr int kGlyphWidth = 5;
  static constexpr int kGlyphHeight = 7;
  static constexpr int kGlyphAdvance = 6;

  /// An image filled with `background`; sizes outside 1..kMaxSide per side are an invalid argument.
  static Result<RgbImage> Create(int width, int height, Rgb background);

  /// An empty 0 x 0 image (all drawing is a no-op); use Create for a real one.
  RgbImage() = default;

  int width() const noexcept { return width_; }
  int height() const noexcept { return height_; }
  /// width * height * 3 bytes, row-major (r, g, b per pixel).
  const std::vector<std::uint8_t>& rgb() const noexcept { return rgb_; }

  bool Contains(int x, int y) const noexcept { return x >= 0 && y >= 0 && x < width_ && y < height_; }
  /// The pixel's colour; black when (x, y) is outside the image.
  Rgb At(int x, int y) const noexcept;

  void SetPixel(int x, int y, Rgb colour) noexcept;
  /// Fills the rectangle with corners (x0, y0) and (x1, y1), both inclusive, in any order.
  void FillRect(int x0, int y0, int x1, int y1, Rgb colour) noexcept;
  /// Outline of the rectangle with outer corners (x0, y0), (x1, y1) (inclusive), `thickness` pixels wide
  /// growing inwards; thickness <= 0 draws nothing.
  void DrawRect(int x0, int y0, int x1, int y1, Rgb colour, int thickness = 1) noexcept;
  /// Segment between two pixel positions (rounded to the nearest pixel centre), stepped one pixel at a time
  /// along its major axis; `thickness` 1..3 pixels (clamped) as a square brush. Non-finite ends: nothing.
  void DrawLine(float x0, float y0, float x1, float y1, Rgb colour, int thickness = 1) noexcept;
  /// Every pixel whose centre lies within `radius` of (cx, cy); non-finite values or radius < 0: nothing.
  void FillDisc(float cx, float cy, float radius, Rgb colour) noexcept;
  /// One line of text with its top-left corner at (x, y); each glyph pixel is a `scale` x `scale` block
  /// (scale 1..64; others draw nothing). Characters outside ASCII 32..126 are drawn as a box.
  void DrawText(int x, int y, const std::string& text, Rgb colour, int scale = 1) noexcept;
  /// The same text rotated 90 degrees counter-clockwise (reads bottom to top); (x, y) is the top-left
  /// corner of the rotated box, which is TextHeight(scale) wide and TextWidth(text, scale) tall.
  void DrawTextUp(int x, int y, const std::string& text, Rgb colour, int scale = 1) noexcept;

  /// Width in pixels of `text` drawn at `scale` (no trailing gap); 0 for empty text.
  static int TextWidth(const std::string& text, int scale = 1) noexcept;
  static int TextHeight(int scale = 1) noexcept { return kGlyphHeight * scale; }

 private:
  RgbImage(int width, int height, Rgb background);
  /// Index of pixel (x, y)'s red byte; (x, y) must be inside.
  std::size_t PixelOffset(int x, int y) const noexcept {
    return (static_cast<std::size_t>(y) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(x)) * 3;
  }
  /// Fills [x0, x1] x [y0, y1] after clipping; coordinates in 64 bits so nothing overflows.
  void FillClipped(std::int64_t x0, std::int64_t y0, std::int64_t x1, std::int64_t y1, Rgb colour) noexcept;
  /// Calls fill(gx, gy) for every set pixel of `text` in unrotated glyph coordinates.
  template <class Fill>
  static void ForEachGlyphPixel(const std::string& text, Fill&& fill);

  int width_ = 0;
  int height_ = 0;
  std::vector<std::uint8_t> rgb_;
};

}  // namespace commerge::platform
