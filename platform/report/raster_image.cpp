// SPDX-License-Identifier: BSD-3-Clause
// RgbImage: clipped pixel, rectangle, line, disc and text drawing (5x7 font drawn for this project).
#include "platform/report/raster_image.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace commerge::platform {

namespace {

/// Glyphs for ASCII 32..126: 7 rows per glyph, the low 5 bits of each row, bit 4 = leftmost column.
constexpr std::uint8_t kFont[95][7] = {
    {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00},  // ' '
    {0x04, 0x04, 0x04, 0x04, 0x04, 0x00, 0x04},  // !
    {0x0A, 0x0A, 0x00, 0x00, 0x00, 0x00, 0x00},  // "
    {0x0A, 0x0A, 0x1F, 0x0A, 0x1F, 0x0A, 0x0A},  // #
    {0x04, 0x0F, 0x14, 0x0E, 0x05, 0x1E, 0x04},  // $
    {0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03},  // %
    {0x0C, 0x12, 0x14, 0x08, 0x15, 0x12, 0x0D},  // &
    {0x04, 0x04, 0x08, 0x00, 0x00, 0x00, 0x00},  // '
    {0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02},  // (
    {0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08},  // )
    {0x00, 0x04, 0x15, 0x0E, 0x15, 0x04, 0x00},  // *
    {0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00},  // +
    {0x00, 0x00, 0x00, 0x00, 0x0C, 0x04, 0x08},  // ,
    {0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00},  // -
    {0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C},  // .
    {0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00},  // /
    {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E},  // 0
    {0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E},  // 1
    {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F},  // 2
    {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E},  // 3
    {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02},  // 4
    {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E},  // 5
    {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E},  // 6
    {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08},  // 7
    {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E},  // 8
    {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C},  // 9
    {0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00},  // :
    {0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x04, 0x08},  // ;
    {0x02, 0x04, 0x08, 0x10, 0x08, 0x04, 0x02},  // <
    {0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00},  // =
    {0x08, 0x04, 0x02, 0x01, 0x02, 0x04, 0x08},  // >
    {0x0E, 0x11, 0x01, 0x02, 0x04, 0x00, 0x04},  // ?
    {0x0E, 0x11, 0x01, 0x0D, 0x15, 0x15, 0x0E},  // @
    {0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11},  // A
    {0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E},  // B
    {0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E},  // C
    {0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C},  // D
    {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F},  // E
    {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10},  // F
    {0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F},  // G
    {0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11},  // H
    {0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E},  // I
    {0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C},  // J
    {0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11},  // K
    {0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F},  // L
    {0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11},  // M
    {0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11},  // N
    {0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E},  // O
    {0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10},  // P
    {0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D},  // Q
    {0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11},  // R
    {0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E},  // S
    {0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04},  // T
    {0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E},  // U
    {0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04},  // V
    {0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A},  // W
    {0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11},  // X
    {0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04},  // Y
    {0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F},  // Z
    {0x0E, 0x08, 0x08, 0x08, 0x08, 0x08, 0x0E},  // [
    {0x00, 0x10, 0x08, 0x04, 0x02, 0x01, 0x00},  // backslash
    {0x0E, 0x02, 0x02, 0x02, 0x02, 0x02, 0x0E},  // ]
    {0x04, 0x0A, 0x11, 0x00, 0x00, 0x00, 0x00},  // ^
    {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F},  // _
    {0x08, 0x04, 0x02, 0x00, 0x00, 0x00, 0x00},  // `
    {0x00, 0x00, 0x0E, 0x01, 0x0F, 0x11, 0x0F},  // a
    {0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x1E},  // b
    {0x00, 0x00, 0x0E, 0x10, 0x10, 0x11, 0x0E},  // c
    {0x01, 0x01, 0x0D, 0x13, 0x11, 0x11, 0x0F},  // d
    {0x00, 0x00, 0x0E, 0x11, 0x1F, 0x10, 0x0E},  // e
    {0x06, 0x09, 0x08, 0x1C, 0x08, 0x08, 0x08},  // f
    {0x00, 0x0F, 0x11, 0x11, 0x0F, 0x01, 0x0E},  // g
    {0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x11},  // h
    {0x04, 0x00, 0x0C, 0x04, 0x04, 0x04, 0x0E},  // i
    {0x02, 0x00, 0x06, 0x02, 0x02, 0x12, 0x0C},  // j
    {0x10, 0x10, 0x12, 0x14, 0x18, 0x14, 0x12},  // k
    {0x0C, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E},  // l
    {0x00, 0x00, 0x1A, 0x15, 0x15, 0x11, 0x11},  // m
    {0x00, 0x00, 0x16, 0x19, 0x11, 0x11, 0x11},  // n
    {0x00, 0x00, 0x0E, 0x11, 0x11, 0x11, 0x0E},  // o
    {0x00, 0x00, 0x1E, 0x11, 0x1E, 0x10, 0x10},  // p
    {0x00, 0x00, 0x0D, 0x13, 0x0F, 0x01, 0x01},  // q
    {0x00, 0x00, 0x16, 0x19, 0x10, 0x10, 0x10},  // r
    {0x00, 0x00, 0x0E, 0x10, 0x0E, 0x01, 0x1E},  // s
    {0x08, 0x08, 0x1C, 0x08, 0x08, 0x09, 0x06},  // t
    {0x00, 0x00, 0x11, 0x11, 0x11, 0x13, 0x0D},  // u
    {0x00, 0x00, 0x11, 0x11, 0x11, 0x0A, 0x04},  // v
    {0x00, 0x00, 0x11, 0x11, 0x15, 0x15, 0x0A},  // w
    {0x00, 0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11},  // x
    {0x00, 0x00, 0x11, 0x11, 0x0F, 0x01, 0x0E},  // y
    {0x00, 0x00, 0x1F, 0x02, 0x04, 0x08, 0x1F},  // z
    {0x02, 0x04, 0x04, 0x08, 0x04, 0x04, 0x02},  // {
    {0x04, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04},  // |
    {0x08, 0x04, 0x04, 0x02, 0x04, 0x04, 0x08},  // }
    {0x00, 0x00, 0x08, 0x15, 0x02, 0x00, 0x00},  // ~
};

/// Drawn for characters outside ASCII 32..126.
constexpr std::uint8_t kBoxGlyph[7] = {0x1F, 0x11, 0x11, 0x11, 0x11, 0x11, 0x1F};

constexpr int kMaxTextScale = 64;

const std::uint8_t* GlyphRows(char c) noexcept {
  const int code = static_cast<unsigned char>(c);
  if (code < 32 || code > 126) return kBoxGlyph;
  return kFont[code - 32];
}

/// Nearest integer of a finite value already known to lie well inside the int range.
int RoundToInt(double v) noexcept { return static_cast<int>(std::floor(v + 0.5)); }

/// Liang-Barsky: shrinks [t0, t1] to the part of the segment inside the box; false when none is.
bool ClipSegment(double x0, double y0, double dx, double dy, double xmin, double ymin, double xmax, double ymax,
                 double* t0, double* t1) noexcept {
  const double p[4] = {-dx, dx, -dy, dy};
  const double q[4] = {x0 - xmin, xmax - x0, y0 - ymin, ymax - y0};
  for (int k = 0; k < 4; ++k) {
    if (p[k] == 0.0) {
      if (q[k] < 0.0) return false;
      continue;
    }
    const double r = q[k] / p[k];
    if (p[k] < 0.0) {
      if (r > *t1) return false;
      *t0 = std::max(*t0, r);
    } else {
      if (r < *t0) return false;
      *t1 = std::min(*t1, r);
    }
  }
  return *t0 <= *t1;
}

}  // namespace

Rgb RobotColour(int robot_index) noexcept {
  static constexpr Rgb kPalette[8] = {
      {31, 119, 180},   // blue
      {255, 127, 14},   // orange
      {44, 160, 44},    // green
      {214, 39, 40},    // red
      {148, 103, 189},  // purple
      {140, 86, 75},    // brown
      {227, 119, 194},  // pink
      {23, 190, 207},   // cyan
  };
  const int i = ((robot_index % 8) + 8) % 8;
  return kPalette[i];
}

RgbImage::RgbImage(int width, int height, Rgb background) : width_(width), height_(height) {
  rgb_.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3);
  for (std::size_t i = 0; i < rgb_.size(); i += 3) {
    rgb_[i] = background.r;
    rgb_[i + 1] = background.g;
    rgb_[i + 2] = background.b;
  }
}

Result<RgbImage> RgbImage::Create(int width, int height, Rgb background) {
  if (width <= 0 || height <= 0 || width > kMaxSide || height > kMaxSide) {
    return InvalidArgument("image size " + std::to_string(width) + " x " + std::to_string(height) +
                           " px is outside 1.." + std::to_string(kMaxSide) + " px per side");
  }
  return RgbImage(width, height, background);
}

Rgb RgbImage::At(int x, int y) const noexcept {
  if (!Contains(x, y)) return Rgb{};
  const std::size_t i = PixelOffset(x, y);
  return Rgb{rgb_[i], rgb_[i + 1], rgb_[i + 2]};
}

void RgbImage::SetPixel(int x, int y, Rgb colour) noexcept {
  if (!Contains(x, y)) return;
  const std::size_t i = PixelOffset(x, y);
  rgb_[i] = colour.r;
  rgb_[i + 1] = colour.g;
  rgb_[i + 2] = colour.b;
}

void RgbImage::FillClipped(std::int64_t x0, std::int64_t y0, std::int64_t x1, std::int64_t y1, Rgb colour) noexcept {
  if (x0 > x1) std::swap(x0, x1);
  if (y0 > y1) std::swap(y0, y1);
  x0 = std::max<std::int64_t>(x0, 0);
  y0 = std::max<std::int64_t>(y0, 0);
  x1 = std::min<std::int64_t>(x1, width_ - 1);
  y1 = std::min<std::int64_t>(y1, height_ - 1);
  for (std::int64_t y = y0; y <= y1; ++y) {
    for (std::int64_t x = x0; x <= x1; ++x) SetPixel(static_cast<int>(x), static_cast<int>(y), colour);
  }
}

void RgbImage::FillRect(int x0, int y0, int x1, int y1, Rgb colour) noexcept { FillClipped(x0, y0, x1, y1, colour); }

void RgbImage::DrawRect(int x0, int y0, int x1, int y1, Rgb colour, int thickness) noexcept {
  if (thickness <= 0) return;
  const std::int64_t left = std::min(x0, x1), right = std::max(x0, x1);
  const std::int64_t top = std::min(y0, y1), bottom = std::max(y0, y1);
  const std::int64_t t = thickness;
  FillClipped(left, top, right, std::min(bottom, top + t - 1), colour);
  FillClipped(left, std::max(top, bottom - t + 1), right, bottom, colour);
  FillClipped(left, top, std::min(right, left + t - 1), bottom, colour);
  FillClipped(std::max(left, right - t + 1), top, right, bottom, colour);
}

void RgbImage::DrawLine(float x0, float y0, float x1, float y1, Rgb colour, int thickness) noexcept {
  if (!std::isfinite(x0) || !std::isfinite(y0) || !std::isfinite(x1) || !std::isfinite(y1)) return;
  if (width_ == 0 || height_ == 0) return;
  const int t = std::clamp(thickness, 1, 3);
  const int lo = -(t - 1) / 2, hi = t / 2;  // brush offsets
  // Clip (in double) to the image grown by the brush and a rounding margin, so the integer walk below
  // never leaves a small range.
  const double ax = static_cast<double>(x0), ay = static_cast<double>(y0);
  const double dx = static_cast<double>(x1) - ax, dy = static_cast<double>(y1) - ay;
  double t0 = 0.0, t1 = 1.0;
  if (!ClipSegment(ax, ay, dx, dy, -3.0, -3.0, width_ + 2.0, height_ + 2.0, &t0, &t1)) return;
  int px = RoundToInt(ax + t0 * dx), py = RoundToInt(ay + t0 * dy);
  const int ex = RoundToInt(ax + t1 * dx), ey = RoundToInt(ay + t1 * dy);
  // Integer Bresenham from (px, py) to (ex, ey).
  const int sx = px < ex ? 1 : -1, sy = py < ey ? 1 : -1;
  const int adx = std::abs(ex - px), ady = -std::abs(ey - py);
  int err = adx + ady;
  while (true) {
    for (int oy = lo; oy <= hi; ++oy) {
      for (int ox = lo; ox <= hi; ++ox) SetPixel(px + ox, py + oy, colour);
    }
    if (px == ex && py == ey) break;
    const int e2 = 2 * err;
    if (e2 >= ady) {
      err += ady;
      px += sx;
    }
    if (e2 <= adx) {
      err += adx;
      py += sy;
    }
  }
}

void RgbImage::FillDisc(float cx, float cy, float radius, Rgb colour) noexcept {
  if (!std::isfinite(cx) || !std::isfinite(cy) || !std::isfinite(radius) || radius < 0.0f) return;
  if (width_ == 0 || height_ == 0) return;
  const double x = static_cast<double>(cx), y = static_cast<double>(cy), r = static_cast<double>(radius);
  const double xa = std::max(std::ceil(x - r), 0.0), xb = std::min(std::floor(x + r), width_ - 1.0);
  const double ya = std::max(std::ceil(y - r), 0.0), yb = std::min(std::floor(y + r), height_ - 1.0);
  if (xa > xb || ya > yb) return;
  const double r2 = r * r;
  for (int py = static_cast<int>(ya); py <= static_cast<int>(yb); ++py) {
    const double ddy = py - y;
    for (int px = static_cast<int>(xa); px <= static_cast<int>(xb); ++px) {
      const double ddx = px - x;
      if (ddx * ddx + ddy * ddy <= r2) SetPixel(px, py, colour);
    }
  }
}

template <class Fill>
void RgbImage::ForEachGlyphPixel(const std::string& text, Fill&& fill) {
  std::int64_t origin = 0;
  for (const char c : text) {
    const std::uint8_t* rows = GlyphRows(c);
    for (int gy = 0; gy < kGlyphHeight; ++gy) {
      for (int gx = 0; gx < kGlyphWidth; ++gx) {
        if (rows[gy] & (0x10u >> gx)) fill(origin + gx, std::int64_t{gy});
      }
    }
    origin += kGlyphAdvance;
  }
}

int RgbImage::TextWidth(const std::string& text, int scale) noexcept {
  if (text.empty() || scale < 1 || scale > kMaxTextScale) return 0;
  const std::int64_t w = (static_cast<std::int64_t>(text.size()) * kGlyphAdvance - 1) * scale;
  return static_cast<int>(std::min<std::int64_t>(w, INT32_MAX));
}

void RgbImage::DrawText(int x, int y, const std::string& text, Rgb colour, int scale) noexcept {
  if (scale < 1 || scale > kMaxTextScale || text.empty()) return;
  const std::int64_t s = scale;
  const std::int64_t w = (static_cast<std::int64_t>(text.size()) * kGlyphAdvance) * s;
  if (x >= width_ || y >= height_ || x + w <= 0 || y + kGlyphHeight * s <= 0) return;
  ForEachGlyphPixel(text, [&](std::int64_t gx, std::int64_t gy) {
    const std::int64_t px = x + gx * s, py = y + gy * s;
    if (px >= width_ || px + s <= 0) return;
    FillClipped(px, py, px + s - 1, py + s - 1, colour);
  });
}

void RgbImage::DrawTextUp(int x, int y, const std::string& text, Rgb colour, int scale) noexcept {
  if (scale < 1 || scale > kMaxTextScale || text.empty()) return;
  const std::int64_t s = scale;
  const std::int64_t w = (static_cast<std::int64_t>(text.size()) * kGlyphAdvance - 1) * s;  // rotated height
  if (x >= width_ || y >= height_ || x + kGlyphHeight * s <= 0 || y + w <= 0) return;
  ForEachGlyphPixel(text, [&](std::int64_t gx, std::int64_t gy) {
    // Unrotated pixel block (gx*s .. +s-1, gy*s .. +s-1) turned counter-clockwise.
    const std::int64_t px = x + gy * s, py = y + w - (gx + 1) * s;
    if (py >= height_ || py + s <= 0) return;
    FillClipped(px, py, px + s - 1, py + s - 1, colour);
  });
}

}  // namespace commerge::platform
