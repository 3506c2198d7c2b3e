// SPDX-License-Identifier: BSD-3-Clause
// Rendering of the report charts: heatmap with MIN pooling, metric plots with equal axes, stacked bars.
#include "platform/report/report_charts.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

namespace commerge::platform {

namespace {

constexpr int kPad = 10;
constexpr int kTextScale = 2;  // axis labels, ticks, legends
constexpr int kTextH = RgbImage::kGlyphHeight * kTextScale;
constexpr int kTitleScale = 3;
constexpr int kTitleH = RgbImage::kGlyphHeight * kTitleScale;
constexpr int kTickLen = 5;
constexpr int kMinImageSide = 64;
constexpr int kMaxGridPx = 4096;
constexpr Rgb kGridColour{225, 225, 225};
constexpr Rgb kFrameColour{120, 120, 120};

/// Anchor colours of the viridis-like map, evenly spaced over t = 0..1.
constexpr Rgb kColourMapAnchors[] = {
    {68, 1, 84},    {72, 40, 120},  {62, 74, 137},  {49, 104, 142},  {38, 130, 142},
    {31, 158, 137}, {53, 183, 121}, {109, 205, 89}, {180, 222, 44}, {253, 231, 37},
};
constexpr int kColourMapAnchorCount = static_cast<int>(sizeof(kColourMapAnchors) / sizeof(kColourMapAnchors[0]));

int Round(double v) { return static_cast<int>(std::floor(v + 0.5)); }

int TextW(const std::string& text) { return RgbImage::TextWidth(text, kTextScale); }

/// Width (in pixels at the label scale) of `chars` characters.
constexpr int CharsW(int chars) { return (chars * RgbImage::kGlyphAdvance - 1) * kTextScale; }

/// Smallest of 1, 2, 5 x 10^k that is >= x (x > 0).
double NiceStepAtLeast(double x) {
  if (!(x > 0.0) || !std::isfinite(x)) return 1.0;
  const double base = std::pow(10.0, std::floor(std::log10(x)));
  for (const double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * base >= x * (1.0 - 1e-9) && m * base > 0.0) return m * base;
  }
  return x;
}

/// A grid/tick value with as many decimals as `step` needs; never "-0".
std::string FormatTick(double value, double step) {
  const int decimals = step >= 1.0 ? 0 : static_cast<int>(std::ceil(-std::log10(step) - 1e-9));
  if (std::fabs(value) < step * 1e-6) value = 0.0;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", std::clamp(decimals, 0, 9), value);
  return buf;
}

Status CheckImageSize(const char* chart, int width, int height) {
  if (width < kMinImageSide || height < kMinImageSide || width > RgbImage::kMaxSide || height > RgbImage::kMaxSide) {
    return InvalidArgument(std::string(chart) + ": image size " + std::to_string(width) + " x " +
                           std::to_string(height) + " px is outside " + std::to_string(kMinImageSide) + ".." +
                           std::to_string(RgbImage::kMaxSide) + " px per side");
  }
  return Status::Ok();
}

int TitleAreaH(const std::string& title) { return title.empty() ? kPad : kPad + kTitleH + kPad; }

void DrawTitle(RgbImage* image, const std::string& title) {
  if (title.empty()) return;
  int scale = kTitleScale;
  while (scale > 1 && RgbImage::TextWidth(title, scale) > image->width() - 2 * kPad) --scale;
  const int w = RgbImage::TextWidth(title, scale);
  const int y = kPad + (kTitleH - RgbImage::TextHeight(scale)) / 2;
  image->DrawText(std::max(kPad, (image->width() - w) / 2), y, title, kChartInk, scale);
}

// Legend: a row of (swatch, name) entries, wrapped to the available width.
struct LegendEntry {
  Rgb colour;
  std::string name;
};
constexpr int kSwatch = 14;
constexpr int kLegendLineH = kTextH + 8;

/// Calls place(entry, x, y) for each entry laid out from (x0, y0) within `width`; returns the lines used.
template <class Place>
int LayoutLegend(const std::vector<LegendEntry>& entries, int x0, int y0, int width, Place&& place) {
  if (entries.empty()) return 0;
  int x = x0, line = 0;
  for (const LegendEntry& e : entries) {
    const int w = kSwatch + 6 + TextW(e.name);
    if (x > x0 && x + w > x0 + width) {
      x = x0;
      ++line;
    }
    place(e, x, y0 + line * kLegendLineH);
    x += w + 20;
  }
  return line + 1;
}

int LegendH(const std::vector<LegendEntry>& entries, int width) {
  const int lines = LayoutLegend(entries, 0, 0, width, [](const LegendEntry&, int, int) {});
  return lines * kLegendLineH;
}

void DrawLegend(RgbImage* image, const std::vector<LegendEntry>& entries, int x0, int y0, int width) {
  LayoutLegend(entries, x0, y0, width, [&](const LegendEntry& e, int x, int y) {
    image->FillRect(x, y, x + kSwatch - 1, y + kSwatch - 1, e.colour);
    image->DrawRect(x, y, x + kSwatch - 1, y + kSwatch - 1, kFrameColour);
    image->DrawText(x + kSwatch + 6, y + (kSwatch - kTextH) / 2, e.name, kChartInk, kTextScale);
  });
}

/// Keeps the smaller of two values, ignoring NaN (NaN only when both are).
inline float MinIgnoringNaN(float a, float b) {
  if (std::isnan(a)) return b;
  if (std::isnan(b)) return a;
  return b < a ? b : a;
}

// ------------------------------------------------------------------------------------------ heatmap

/// Pixels of one heatmap axis: n cells over `px` pixels.
struct GridAxis {
  int cells = 0;
  int px = 0;
  /// Cells shown by pixel p: [CellBegin(p), CellEnd(p)).
  int CellBegin(int p) const {
    return static_cast<int>(static_cast<std::int64_t>(p) * cells / px);
  }
  int CellEnd(int p) const {
    const int end = static_cast<int>(static_cast<std::int64_t>(p + 1) * cells / px);
    return std::max(end, CellBegin(p) + 1);
  }
};

GridAxis MakeAxis(int cells, int max_px) {
  GridAxis axis;
  axis.cells = cells;
  axis.px = cells <= max_px ? cells * (max_px / cells) : max_px;
  return axis;
}

/// First and last pixel showing each cell of an axis.
void CellPixelRanges(const GridAxis& axis, std::vector<int>* first, std::vector<int>* last) {
  first->assign(static_cast<std::size_t>(axis.cells), std::numeric_limits<int>::max());
  last->assign(static_cast<std::size_t>(axis.cells), -1);
  for (int p = 0; p < axis.px; ++p) {
    for (int c = axis.CellBegin(p); c < axis.CellEnd(p); ++c) {
      (*first)[static_cast<std::size_t>(c)] = std::min((*first)[static_cast<std::size_t>(c)], p);
      (*last)[static_cast<std::size_t>(c)] = std::max((*last)[static_cast<std::size_t>(c)], p);
    }
  }
}

int DecimalDigits(int v) { return static_cast<int>(std::to_string(v).size()); }

Status CheckCell(const HeatmapInput& in, int row, int col, const std::string& what) {
  if (row < 0 || row >= in.rows || col < 0 || col >= in.cols) {
    return InvalidArgument("heatmap: " + what + " cell (" + std::to_string(row) + ", " + std::to_string(col) +
                           ") is outside the " + std::to_string(in.rows) + " x " + std::to_string(in.cols) + " grid");
  }
  return Status::Ok();
}

}  // namespace

Rgb ColourMap(float t) noexcept {
  if (std::isnan(t)) return kNoValueColour;
  t = std::clamp(t, 0.0f, 1.0f);
  const float pos = t * static_cast<float>(kColourMapAnchorCount - 1);
  const int i = std::min(static_cast<int>(pos), kColourMapAnchorCount - 2);
  const float f = pos - static_cast<float>(i);
  const Rgb a = kColourMapAnchors[i], b = kColourMapAnchors[i + 1];
  auto mix = [f](std::uint8_t u, std::uint8_t v) {
    const float value = static_cast<float>(u) + (static_cast<float>(v) - static_cast<float>(u)) * f;
    return static_cast<std::uint8_t>(std::clamp(std::floor(value + 0.5f), 0.0f, 255.0f));
  };
  return Rgb{mix(a.r, b.r), mix(a.g, b.g), mix(a.b, b.b)};
}

std::string HumanBytes(double bytes) {
  if (!(bytes >= 0.0) || !std::isfinite(bytes)) return "?";
  static const char* const kUnits[] = {"B", "kB", "MB", "GB", "TB", "PB"};
  int unit = 0;
  double v = bytes;
  while (unit < 5 && v >= 999.5) {
    v /= 1000.0;
    ++unit;
  }
  char buf[64];
  if (unit == 0) {
    std::snprintf(buf, sizeof buf, "%.0f B", v);
  } else if (v < 99.95) {
    std::snprintf(buf, sizeof buf, "%.1f %s", v, kUnits[unit]);
  } else {
    std::snprintf(buf, sizeof buf, "%.0f %s", v, kUnits[unit]);
  }
  return buf;
}

Result<HeatmapLayout> LayoutHeatmap(const HeatmapInput& in) {
  if (in.rows < 1 || in.cols < 1) {
    return InvalidArgument("heatmap: grid " + std::to_string(in.rows) + " x " + std::to_string(in.cols) +
                           " has no cells");
  }
  const std::size_t cells = static_cast<std::size_t>(in.rows) * static_cast<std::size_t>(in.cols);
  if (in.values.size() != cells) {
    return InvalidArgument("heatmap: " + std::to_string(in.values.size()) + " values for a " +
                           std::to_string(in.rows) + " x " + std::to_string(in.cols) + " grid (expected " +
                           std::to_string(cells) + ")");
  }
  if (in.max_grid_px < 1 || in.max_grid_px > kMaxGridPx) {
    return InvalidArgument("heatmap: max_grid_px " + std::to_string(in.max_grid_px) + " is outside 1.." +
                           std::to_string(kMaxGridPx));
  }
  for (const HeatmapRect& r : in.rects) {
    Status s = CheckCell(in, r.row0, r.col0, "rectangle corner");
    if (s.ok()) s = CheckCell(in, r.row1, r.col1, "rectangle corner");
    if (!s.ok()) return s;
    if (r.thickness_px < 1 || r.thickness_px > 16) {
      return InvalidArgument("heatmap: rectangle thickness " + std::to_string(r.thickness_px) +
                             " px is outside 1..16");
    }
  }
  for (const HeatmapMark& m : in.marks) {
    Status s = CheckCell(in, m.row, m.col, "marked");
    if (!s.ok()) return s;
  }

  HeatmapLayout layout;
  layout.vmin = in.vmin;
  layout.vmax = in.vmax;
  if (!(in.vmax > in.vmin) || !std::isfinite(in.vmin) || !std::isfinite(in.vmax)) {
    float lo = std::numeric_limits<float>::infinity(), hi = -std::numeric_limits<float>::infinity();
    for (const float v : in.values) {
      if (!std::isfinite(v)) continue;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    if (!(lo <= hi)) lo = hi = 0.0f;
    if (!(hi > lo)) hi = lo + 1.0f;
    layout.vmin = lo;
    layout.vmax = hi;
  }

  const GridAxis xs = MakeAxis(in.cols, in.max_grid_px), ys = MakeAxis(in.rows, in.max_grid_px);
  layout.grid_width_px = xs.px;
  layout.grid_height_px = ys.px;
  const int row_ticks_w = CharsW(DecimalDigits(in.rows - 1));
  layout.grid_x_px = kPad + kTextH + 8 + row_ticks_w + 4 + kTickLen;
  layout.grid_y_px = std::max(TitleAreaH(in.title), kPad + kTextH / 2);
  layout.colour_bar_x_px = layout.grid_x_px + layout.grid_width_px + 16;
  layout.colour_bar_width_px = 18;
  const double vmin = static_cast<double>(layout.vmin), vmax = static_cast<double>(layout.vmax);
  const int bar_labels_w = std::max({TextW(FormatNumber(vmin, kChartDigits)), TextW(FormatNumber(vmax, kChartDigits)),
                                     TextW(FormatNumber(0.5 * (vmin + vmax), kChartDigits)), TextW("n/a")});
  layout.image_width_px = layout.colour_bar_x_px + layout.colour_bar_width_px + kTickLen + 4 + bar_labels_w + kPad;
  layout.image_height_px = layout.grid_y_px + layout.grid_height_px + kTickLen + 4 + kTextH + 8 + kTextH + kPad;
  // A title wider than the grid widens the image.
  if (!in.title.empty()) {
    layout.image_width_px = std::max(layout.image_width_px, RgbImage::TextWidth(in.title, 2) + 2 * kPad);
  }
  layout.image_width_px = std::min(layout.image_width_px, RgbImage::kMaxSide);
  return layout;
}

Result<RgbImage> RenderHeatmap(const HeatmapInput& in) {
  auto laid = LayoutHeatmap(in);
  if (!laid.ok()) return laid.status();
  const HeatmapLayout& L = *laid;
  auto created = RgbImage::Create(L.image_width_px, L.image_height_px, in.background);
  if (!created.ok()) return created.status();
  RgbImage image = std::move(*created);

  // Cells: each pixel shows the minimum of the cells it covers.
  const GridAxis xs = MakeAxis(in.cols, in.max_grid_px), ys = MakeAxis(in.rows, in.max_grid_px);
  const float range = L.vmax - L.vmin;
  std::vector<float> row_min(static_cast<std::size_t>(in.cols));
  int cached_begin = -1, cached_end = -1;
  const std::size_t cols = static_cast<std::size_t>(in.cols);
  for (int py = 0; py < ys.px; ++py) {
    const int rb = ys.CellBegin(py), re = ys.CellEnd(py);
    if (rb != cached_begin || re != cached_end) {
      std::fill(row_min.begin(), row_min.end(), std::numeric_limits<float>::quiet_NaN());
      for (int r = rb; r < re; ++r) {
        const float* row = in.values.data() + static_cast<std::size_t>(r) * cols;
        for (std::size_t c = 0; c < cols; ++c) row_min[c] = MinIgnoringNaN(row_min[c], row[c]);
      }
      cached_begin = rb;
      cached_end = re;
    }
    for (int px = 0; px < xs.px; ++px) {
      float v = std::numeric_limits<float>::quiet_NaN();
      for (int c = xs.CellBegin(px); c < xs.CellEnd(px); ++c) {
        v = MinIgnoringNaN(v, row_min[static_cast<std::size_t>(c)]);
      }
      image.SetPixel(L.grid_x_px + px, L.grid_y_px + py, ColourMap((v - L.vmin) / range));
    }
  }

  // Overlays: rectangles (a ring just outside the cells), then marks.
  std::vector<int> col_first, col_last, row_first, row_last;
  CellPixelRanges(xs, &col_first, &col_last);
  CellPixelRanges(ys, &row_first, &row_last);
  auto at = [](const std::vector<int>& v, int i) { return v[static_cast<std::size_t>(i)]; };
  for (const HeatmapRect& r : in.rects) {
    const int c0 = std::min(r.col0, r.col1), c1 = std::max(r.col0, r.col1);
    const int r0 = std::min(r.row0, r.row1), r1 = std::max(r.row0, r.row1);
    const int t = r.thickness_px;
    image.DrawRect(L.grid_x_px + at(col_first, c0) - t, L.grid_y_px + at(row_first, r0) - t,
                   L.grid_x_px + at(col_last, c1) + t, L.grid_y_px + at(row_last, r1) + t, r.colour, t);
  }
  for (const HeatmapMark& m : in.marks) {
    // Centred on the pixel nearest the cell's centre, so the dot is symmetric.
    const float cx = static_cast<float>(L.grid_x_px + (at(col_first, m.col) + at(col_last, m.col) + 1) / 2);
    const float cy = static_cast<float>(L.grid_y_px + (at(row_first, m.row) + at(row_last, m.row) + 1) / 2);
    image.FillDisc(cx, cy, in.mark_radius_px + 1.0f, kChartInk);
    image.FillDisc(cx, cy, in.mark_radius_px, m.colour);
  }

  // Frame, ticks and labels.
  const int gx0 = L.grid_x_px, gy0 = L.grid_y_px;
  const int gx1 = gx0 + L.grid_width_px - 1, gy1 = gy0 + L.grid_height_px - 1;
  image.DrawRect(gx0 - 1, gy0 - 1, gx1 + 1, gy1 + 1, kFrameColour);
  // Tick steps: at most ~8 ticks per axis and labels that do not touch.
  const double col_label_px = CharsW(DecimalDigits(in.cols - 1)) + 12.0;
  const int col_step = std::max(1, static_cast<int>(NiceStepAtLeast(
                                       std::max(in.cols / 8.0, in.cols * col_label_px / L.grid_width_px))));
  for (int c = 0; c < in.cols; c += col_step) {
    const int x = gx0 + (at(col_first, c) + at(col_last, c)) / 2;
    image.FillRect(x, gy1 + 2, x, gy1 + 1 + kTickLen, kChartInk);
    const std::string label = std::to_string(c);
    image.DrawText(x - TextW(label) / 2, gy1 + 2 + kTickLen + 3, label, kChartInk, kTextScale);
  }
  const int row_step = std::max(1, static_cast<int>(NiceStepAtLeast(
                                       std::max(in.rows / 8.0, in.rows * (kTextH + 6.0) / L.grid_height_px))));
  for (int r = 0; r < in.rows; r += row_step) {
    const int y = gy0 + (at(row_first, r) + at(row_last, r)) / 2;
    image.FillRect(gx0 - 1 - kTickLen, y, gx0 - 2, y, kChartInk);
    const std::string label = std::to_string(r);
    image.DrawText(gx0 - 2 - kTickLen - 4 - TextW(label), y - kTextH / 2, label, kChartInk, kTextScale);
  }
  const int col_label_y = gy1 + 2 + kTickLen + 3 + kTextH + 8;
  // Axis names at the label scale, or smaller when longer than the grid.
  const int col_scale = TextW(in.col_label) <= L.grid_width_px ? kTextScale : 1;
  const int row_scale = TextW(in.row_label) <= L.grid_height_px ? kTextScale : 1;
  image.DrawText(gx0 + (L.grid_width_px - RgbImage::TextWidth(in.col_label, col_scale)) / 2, col_label_y, in.col_label,
                 kChartInk, col_scale);
  image.DrawTextUp(kPad + kTextH - RgbImage::TextHeight(row_scale),
                   gy0 + (L.grid_height_px - RgbImage::TextWidth(in.row_label, row_scale)) / 2, in.row_label, kChartInk,
                   row_scale);

  // Colour bar: vmax at the top row of the grid, vmin at its bottom row.
  const int bx0 = L.colour_bar_x_px, bx1 = bx0 + L.colour_bar_width_px - 1;
  for (int y = gy0; y <= gy1; ++y) {
    const float t = gy1 == gy0 ? 1.0f : static_cast<float>(gy1 - y) / static_cast<float>(gy1 - gy0);
    image.FillRect(bx0, y, bx1, y, ColourMap(t));
  }
  image.DrawRect(bx0 - 1, gy0 - 1, bx1 + 1, gy1 + 1, kFrameColour);
  auto bar_label = [&](int y, double value) {
    image.FillRect(bx1 + 2, y, bx1 + 1 + kTickLen, y, kChartInk);
    image.DrawText(bx1 + 2 + kTickLen + 3, y - kTextH / 2, FormatNumber(value, kChartDigits), kChartInk, kTextScale);
  };
  bar_label(gy0, static_cast<double>(L.vmax));
  bar_label(gy1, static_cast<double>(L.vmin));
  if (L.grid_height_px >= 4 * kTextH) {
    bar_label((gy0 + gy1) / 2, 0.5 * (static_cast<double>(L.vmin) + static_cast<double>(L.vmax)));
  }
  const bool any_nan = std::any_of(in.values.begin(), in.values.end(), [](float v) { return std::isnan(v); });
  if (any_nan) {
    const int y = gy1 + 2 + kTickLen + 3;
    image.FillRect(bx0, y, bx1, y + kTextH - 1, kNoValueColour);
    image.DrawRect(bx0 - 1, y - 1, bx1 + 1, y + kTextH, kFrameColour);
    image.DrawText(bx1 + 2 + kTickLen + 3, y, "n/a", kChartInk, kTextScale);
  }
  DrawTitle(&image, in.title);
  return image;
}

// ------------------------------------------------------------------------------------------ metric plots

namespace {

constexpr int kTickLabelChars = 6;

/// Frame of a metric plot: margins around the plot area for title, legend, tick labels and axis names.
Result<MetricLayout> LayoutMetric(const char* chart, int width, int height, const std::string& title,
                                  const std::vector<LegendEntry>& legend, double bx0, double by0, double bx1,
                                  double by1, double pad_fraction) {
  Status size = CheckImageSize(chart, width, height);
  if (!size.ok()) return size;
  MetricLayout L;
  L.image_width_px = width;
  L.image_height_px = height;
  const int legend_h = LegendH(legend, width - 2 * kPad);
  L.plot_x_px = kPad + kTextH + 8 + CharsW(kTickLabelChars) + 4 + kTickLen + 1;
  L.plot_y_px = TitleAreaH(title) + (legend_h > 0 ? legend_h + kPad : 0) + kTextH / 2;
  L.plot_width_px = width - L.plot_x_px - kPad - CharsW(3);
  L.plot_height_px = height - L.plot_y_px - (1 + kTickLen + 3 + kTextH + 8 + kTextH + kPad);
  if (L.plot_width_px < 16 || L.plot_height_px < 16) {
    return InvalidArgument(std::string(chart) + ": image " + std::to_string(width) + " x " + std::to_string(height) +
                           " px leaves no room for the plot after the title, legend and labels");
  }
  if (!(bx0 <= bx1) || !(by0 <= by1)) {  // nothing finite to show
    bx0 = by0 = -1.0;
    bx1 = by1 = 1.0;
  }
  double sx = bx1 - bx0, sy = by1 - by0;
  // Spans below 1 mm (or below float resolution far from the origin) count as a single position.
  const double scale_floor =
      std::max(1e-3, 1e-7 * std::max({std::fabs(bx0), std::fabs(bx1), std::fabs(by0), std::fabs(by1)}));
  if (sx < scale_floor && sy < scale_floor) {  // a single position: show 2 m around it
    bx0 -= 1.0;
    bx1 += 1.0;
    by0 -= 1.0;
    by1 += 1.0;
    sx = sy = 2.0;
  }
  sx = std::max(sx, scale_floor);
  sy = std::max(sy, scale_floor);
  sx *= 1.0 + 2.0 * pad_fraction;
  sy *= 1.0 + 2.0 * pad_fraction;
  const double w = L.plot_width_px - 1, h = L.plot_height_px - 1;
  L.px_per_m = std::min(w / sx, h / sy);
  L.min_x_m = 0.5 * (bx0 + bx1) - 0.5 * w / L.px_per_m;
  L.min_y_m = 0.5 * (by0 + by1) - 0.5 * h / L.px_per_m;
  L.grid_step_m = NiceStepAtLeast(std::max(w, h) / L.px_per_m / 10.0);
  return L;
}

bool InPlot(const MetricLayout& L, int x, int y) {
  return x >= L.plot_x_px && y >= L.plot_y_px && x < L.plot_x_px + L.plot_width_px &&
         y < L.plot_y_px + L.plot_height_px;
}

/// Grid lines (behind the data), frame, tick labels in metres and the axis names.
void DrawMetricFrame(RgbImage* image, const MetricLayout& L) {
  const int x0 = L.plot_x_px, y0 = L.plot_y_px;
  const int x1 = x0 + L.plot_width_px - 1, y1 = y0 + L.plot_height_px - 1;
  const double step = L.grid_step_m;
  const double max_x = L.min_x_m + (L.plot_width_px - 1) / L.px_per_m;
  const double max_y = L.min_y_m + (L.plot_height_px - 1) / L.px_per_m;
  // The step gives about 4..10 lines; the check only guards the loops against a degenerate layout.
  const bool grid = step > 0.0 && std::max(max_x - L.min_x_m, max_y - L.min_y_m) / step < 100.0;
  for (double k = std::ceil(L.min_x_m / step); grid && k * step <= max_x; k += 1.0) {
    const int x = Round(L.PixelX(k * step));
    if (x < x0 || x > x1) continue;
    image->FillRect(x, y0, x, y1, kGridColour);
    image->FillRect(x, y1 + 2, x, y1 + 1 + kTickLen, kChartInk);
    const std::string label = FormatTick(k * step, step);
    image->DrawText(x - TextW(label) / 2, y1 + 2 + kTickLen + 3, label, kChartInk, kTextScale);
  }
  for (double k = std::ceil(L.min_y_m / step); grid && k * step <= max_y; k += 1.0) {
    const int y = Round(L.PixelY(k * step));
    if (y < y0 || y > y1) continue;
    image->FillRect(x0, y, x1, y, kGridColour);
    image->FillRect(x0 - 1 - kTickLen, y, x0 - 2, y, kChartInk);
    const std::string label = FormatTick(k * step, step);
    image->DrawText(x0 - 2 - kTickLen - 4 - TextW(label), y - kTextH / 2, label, kChartInk, kTextScale);
  }
  image->DrawRect(x0 - 1, y0 - 1, x1 + 1, y1 + 1, kFrameColour);
  const std::string x_name = "x [m]", y_name = "y [m]";
  image->DrawText(x0 + (L.plot_width_px - TextW(x_name)) / 2, y1 + 2 + kTickLen + 3 + kTextH + 8, x_name, kChartInk,
                  kTextScale);
  image->DrawTextUp(kPad, y0 + (L.plot_height_px - TextW(y_name)) / 2, y_name, kChartInk, kTextScale);
}

void DrawMetricDecorations(RgbImage* image, const MetricLayout& L, const std::string& title,
                           const std::vector<LegendEntry>& legend) {
  DrawTitle(image, title);
  DrawLegend(image, legend, kPad, TitleAreaH(title), L.image_width_px - 2 * kPad);
}

std::vector<LegendEntry> TrajectoryLegend(const TrajectoryPlotInput& in) {
  std::vector<LegendEntry> legend;
  for (const TrajectorySeries& r : in.robots) legend.push_back({RobotColour(r.robot_index), r.name});
  return legend;
}

std::vector<LegendEntry> TopViewLegend(const TopViewInput& in) {
  std::vector<LegendEntry> legend;
  if (!in.robot_names.empty()) {
    for (std::size_t i = 0; i < in.robot_names.size(); ++i) {
      legend.push_back({RobotColour(static_cast<int>(i)), in.robot_names[i]});
    }
    return legend;
  }
  std::vector<bool> present(65536, false);
  if (in.robot_ids.empty()) {
    if (!in.points.empty()) present[0] = true;
  } else {
    for (const std::uint16_t id : in.robot_ids) present[id] = true;
  }
  for (int id = 0; id < 65536 && legend.size() < 16; ++id) {
    if (present[static_cast<std::size_t>(id)]) legend.push_back({RobotColour(id), "robot " + std::to_string(id)});
  }
  return legend;
}

}  // namespace

Result<MetricLayout> LayoutTrajectories(const TrajectoryPlotInput& in) {
  double bx0 = std::numeric_limits<double>::infinity(), by0 = bx0, bx1 = -bx0, by1 = -bx0;
  for (const TrajectorySeries& r : in.robots) {
    for (const int i : r.highlighted) {
      if (i < 0 || static_cast<std::size_t>(i) >= r.path.size()) {
        return InvalidArgument("trajectories: highlighted index " + std::to_string(i) + " of robot '" + r.name +
                               "' is outside its path of " + std::to_string(r.path.size()) + " positions");
      }
    }
    for (const PlotPointM& p : r.path) {
      if (!std::isfinite(p.x_m) || !std::isfinite(p.y_m)) continue;
      bx0 = std::min(bx0, static_cast<double>(p.x_m));
      bx1 = std::max(bx1, static_cast<double>(p.x_m));
      by0 = std::min(by0, static_cast<double>(p.y_m));
      by1 = std::max(by1, static_cast<double>(p.y_m));
    }
  }
  return LayoutMetric("trajectories", in.width_px, in.height_px, in.title, TrajectoryLegend(in), bx0, by0, bx1, by1,
                      0.04);
}

Result<RgbImage> RenderTrajectories(const TrajectoryPlotInput& in) {
  auto laid = LayoutTrajectories(in);
  if (!laid.ok()) return laid.status();
  const MetricLayout& L = *laid;
  auto created = RgbImage::Create(L.image_width_px, L.image_height_px, in.background);
  if (!created.ok()) return created.status();
  RgbImage image = std::move(*created);
  DrawMetricFrame(&image, L);
  // Pixel centres (lines round their ends anyway; discs become symmetric).
  auto px = [&](const PlotPointM& p) {
    return static_cast<float>(std::floor(L.PixelX(static_cast<double>(p.x_m)) + 0.5));
  };
  auto py = [&](const PlotPointM& p) {
    return static_cast<float>(std::floor(L.PixelY(static_cast<double>(p.y_m)) + 0.5));
  };
  for (const TrajectorySeries& r : in.robots) {
    const Rgb colour = RobotColour(r.robot_index);
    for (std::size_t i = 1; i < r.path.size(); ++i) {
      image.DrawLine(px(r.path[i - 1]), py(r.path[i - 1]), px(r.path[i]), py(r.path[i]), colour, in.line_thickness_px);
    }
    if (r.path.size() == 1) image.FillDisc(px(r.path[0]), py(r.path[0]), 1.0f, colour);
  }
  // Highlights after all paths, so no later path hides them.
  for (const TrajectorySeries& r : in.robots) {
    const Rgb colour = RobotColour(r.robot_index);
    for (const int i : r.highlighted) {
      const PlotPointM& p = r.path[static_cast<std::size_t>(i)];
      image.FillDisc(px(p), py(p), in.highlight_radius_px + 1.0f, kChartInk);
      image.FillDisc(px(p), py(p), in.highlight_radius_px, colour);
    }
  }
  DrawMetricDecorations(&image, L, in.title, TrajectoryLegend(in));
  return image;
}

Result<MetricLayout> LayoutTopView(const TopViewInput& in) {
  if (!in.robot_ids.empty() && in.robot_ids.size() != in.points.size()) {
    return InvalidArgument("top view: " + std::to_string(in.robot_ids.size()) + " robot ids for " +
                           std::to_string(in.points.size()) + " points (expected none or one per point)");
  }
  double bx0 = std::numeric_limits<double>::infinity(), by0 = bx0, bx1 = -bx0, by1 = -bx0;
  double pad = 0.02;
  if (in.use_bounds) {
    const BoundsM& b = in.bounds;
    if (!std::isfinite(b.min_x_m) || !std::isfinite(b.min_y_m) || !std::isfinite(b.max_x_m) ||
        !std::isfinite(b.max_y_m) || !(b.max_x_m > b.min_x_m) || !(b.max_y_m > b.min_y_m)) {
      return InvalidArgument("top view: bounds x " + FormatNumber(static_cast<double>(b.min_x_m), kChartDigits) + ".." +
                             FormatNumber(static_cast<double>(b.max_x_m), kChartDigits) + " m, y " +
                             FormatNumber(static_cast<double>(b.min_y_m), kChartDigits) + ".." +
                             FormatNumber(static_cast<double>(b.max_y_m), kChartDigits) + " m are empty or not finite");
    }
    bx0 = static_cast<double>(b.min_x_m);
    bx1 = static_cast<double>(b.max_x_m);
    by0 = static_cast<double>(b.min_y_m);
    by1 = static_cast<double>(b.max_y_m);
    pad = 0.0;
  } else {
    for (const PointXYZI& p : in.points) {
      if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
      bx0 = std::min(bx0, static_cast<double>(p.x));
      bx1 = std::max(bx1, static_cast<double>(p.x));
      by0 = std::min(by0, static_cast<double>(p.y));
      by1 = std::max(by1, static_cast<double>(p.y));
    }
  }
  return LayoutMetric("top view", in.width_px, in.height_px, in.title, TopViewLegend(in), bx0, by0, bx1, by1, pad);
}

Result<RgbImage> RenderTopView(const TopViewInput& in) {
  auto laid = LayoutTopView(in);
  if (!laid.ok()) return laid.status();
  const MetricLayout& L = *laid;
  auto created = RgbImage::Create(L.image_width_px, L.image_height_px, in.background);
  if (!created.ok()) return created.status();
  RgbImage image = std::move(*created);
  DrawMetricFrame(&image, L);
  for (std::size_t i = 0; i < in.points.size(); ++i) {
    const PointXYZI& p = in.points[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
    const double fx = L.PixelX(static_cast<double>(p.x)), fy = L.PixelY(static_cast<double>(p.y));
    if (!(fx > -1.0 && fy > -1.0 && fx < L.image_width_px && fy < L.image_height_px)) continue;
    const int x = Round(fx), y = Round(fy);
    if (!InPlot(L, x, y)) continue;
    image.SetPixel(x, y, RobotColour(in.robot_ids.empty() ? 0 : in.robot_ids[i]));
  }
  DrawMetricDecorations(&image, L, in.title, TopViewLegend(in));
  return image;
}

// ------------------------------------------------------------------------------------------- bar chart

int BarChartLayout::HeightPx(double value) const noexcept {
  double f = 0.0;
  if (log_scale) {
    if (value > 0.0) f = (std::log10(value) - std::log10(axis_min)) / (std::log10(axis_max) - std::log10(axis_min));
  } else {
    f = (value - axis_min) / (axis_max - axis_min);
  }
  if (!(f > 0.0)) return 0;
  return Round(std::min(f, 1.0) * plot_height_px);
}

namespace {

std::string FormatValue(BarValueFormat format, double v) {
  return format == BarValueFormat::kBytes ? HumanBytes(v) : FormatNumber(v, kChartDigits);
}

/// Axis tick text: as FormatValue, without a ".0" ("20 MB", not "20.0 MB").
std::string FormatTickValue(BarValueFormat format, double v) {
  std::string text = FormatValue(format, v);
  const std::size_t zero = text.find(".0 ");
  if (zero != std::string::npos) text.erase(zero, 2);
  return text;
}

/// One legend entry per series: its name, in its colour (RobotColour(index) when `colours` is empty).
std::vector<LegendEntry> SeriesLegendOf(const std::vector<std::string>& names, const std::vector<Rgb>& colours) {
  std::vector<LegendEntry> legend;
  for (std::size_t s = 0; s < names.size(); ++s) {
    legend.push_back({colours.empty() ? RobotColour(static_cast<int>(s)) : colours[s], names[s]});
  }
  return legend;
}

std::vector<LegendEntry> BarLegend(const BarChartInput& in) { return SeriesLegendOf(in.series, in.series_colours); }

/// Stacked charts: at least one row (group, sample) and one series, rows x series values, no or one colour per
/// series. `rows_word` names the rows in the message.
Status CheckStackShape(const char* chart, const char* rows_word, std::size_t rows, std::size_t series,
                       std::size_t values, std::size_t colours) {
  if (rows == 0 || series == 0) {
    return InvalidArgument(std::string(chart) + ": needs at least one " + rows_word + " and one series (got " +
                           std::to_string(rows) + " and " + std::to_string(series) + ")");
  }
  if (values != rows * series) {
    return InvalidArgument(std::string(chart) + ": " + std::to_string(values) + " values for " + std::to_string(rows) +
                           " " + rows_word + "s x " + std::to_string(series) + " series");
  }
  if (colours != 0 && colours != series) {
    return InvalidArgument(std::string(chart) + ": " + std::to_string(colours) + " colours for " +
                           std::to_string(series) + " series");
  }
  return Status::Ok();
}

double GroupTotal(const BarChartInput& in, std::size_t g) {
  double total = 0.0;
  for (std::size_t s = 0; s < in.series.size(); ++s) total += in.values[g * in.series.size() + s];
  return total;
}

/// Value-axis ticks: multiples of a nice step (linear) or powers of ten (log).
std::vector<double> ValueTicks(const BarChartLayout& L) {
  std::vector<double> ticks;
  if (L.log_scale) {
    for (double v = L.axis_min; v <= L.axis_max * 1.000001; v *= 10.0) ticks.push_back(v);
  } else {
    const double step = NiceStepAtLeast(L.axis_max / 8.0);
    for (double k = 0.0; k * step <= L.axis_max * 1.000001; k += 1.0) ticks.push_back(k * step);
  }
  return ticks;
}

}  // namespace

Result<BarChartLayout> LayoutBarChart(const BarChartInput& in) {
  Status size = CheckImageSize("bar chart", in.width_px, in.height_px);
  if (!size.ok()) return size;
  if (Status shape = CheckStackShape("bar chart", "group", in.groups.size(), in.series.size(), in.values.size(),
                                     in.series_colours.size());
      !shape.ok()) {
    return shape;
  }
  double min_positive = std::numeric_limits<double>::infinity(), max_total = 0.0;
  for (std::size_t i = 0; i < in.values.size(); ++i) {
    const double v = in.values[i];
    if (!std::isfinite(v) || v < 0.0) {
      return InvalidArgument("bar chart: value " + FormatNumber(v, kChartDigits) + " of group '" +
                             in.groups[i / in.series.size()] + "', series '" + in.series[i % in.series.size()] +
                             "' is not a finite value >= 0");
    }
    if (v > 0.0) min_positive = std::min(min_positive, v);
  }
  for (std::size_t g = 0; g < in.groups.size(); ++g) max_total = std::max(max_total, GroupTotal(in, g));

  BarChartLayout L;
  L.image_width_px = in.width_px;
  L.image_height_px = in.height_px;
  L.log_scale = in.log_scale;
  if (in.log_scale) {
    if (!(max_total > 0.0)) {
      L.axis_min = 1.0;
      L.axis_max = 10.0;
    } else {
      // A power of ten strictly below the smallest value, so every positive value has a visible bar.
      L.axis_min = std::pow(10.0, std::ceil(std::log10(min_positive) - 1e-12) - 1.0);
      L.axis_max = std::pow(10.0, std::ceil(std::log10(max_total) - 1e-12));
      if (!(L.axis_max > L.axis_min)) L.axis_max = L.axis_min * 10.0;
    }
  } else {
    const double top = max_total > 0.0 ? max_total : 1.0;
    const double step = NiceStepAtLeast(top / 8.0);
    L.axis_min = 0.0;
    L.axis_max = std::ceil(top / step - 1e-9) * step;
  }
  const int legend_h = LegendH(BarLegend(in), in.width_px - 2 * kPad);
  L.plot_x_px = kPad + kTextH + 8 + CharsW(9) + 4 + kTickLen + 1;
  L.plot_y_px = TitleAreaH(in.title) + legend_h + kPad + kTextH + 6;  // room for the value labels on top
  L.plot_width_px = in.width_px - L.plot_x_px - 2 * kPad;
  L.plot_height_px = in.height_px - L.plot_y_px - (2 + kTickLen + 4 + kTextH + kPad);
  if (L.plot_width_px < 16 || L.plot_height_px < 16) {
    return InvalidArgument("bar chart: image " + std::to_string(in.width_px) + " x " + std::to_string(in.height_px) +
                           " px leaves no room for the bars after the title, legend and labels");
  }
  const double slot = static_cast<double>(L.plot_width_px) / static_cast<double>(in.groups.size());
  const int bar_w = std::max(1, Round(slot * 0.6));
  for (std::size_t g = 0; g < in.groups.size(); ++g) {
    const int x0 = L.plot_x_px + Round(slot * (static_cast<double>(g) + 0.5) - bar_w / 2.0);
    L.bar_x0_px.push_back(x0);
    L.bar_x1_px.push_back(x0 + bar_w - 1);
  }
  return L;
}

Result<RgbImage> RenderBarChart(const BarChartInput& in) {
  auto laid = LayoutBarChart(in);
  if (!laid.ok()) return laid.status();
  const BarChartLayout& L = *laid;
  auto created = RgbImage::Create(L.image_width_px, L.image_height_px, in.background);
  if (!created.ok()) return created.status();
  RgbImage image = std::move(*created);
  const int x0 = L.plot_x_px, x1 = x0 + L.plot_width_px - 1;
  const int y0 = L.plot_y_px, bottom = y0 + L.plot_height_px - 1;

  for (const double v : ValueTicks(L)) {
    const int y = bottom - L.HeightPx(v) + 1;
    if (y > bottom + 1 || y < y0) continue;
    if (y <= bottom) image.FillRect(x0, y, x1, y, kGridColour);
    image.FillRect(x0 - 1 - kTickLen, y, x0 - 2, y, kChartInk);
    const std::string label = FormatTickValue(in.value_format, v);
    image.DrawText(x0 - 2 - kTickLen - 4 - TextW(label), y - kTextH / 2, label, kChartInk, kTextScale);
  }

  const std::vector<LegendEntry> legend = BarLegend(in);
  const std::size_t n_series = in.series.size();
  for (std::size_t g = 0; g < in.groups.size(); ++g) {
    double cum = 0.0;
    for (std::size_t s = 0; s < n_series; ++s) {
      const int h0 = L.HeightPx(cum);
      cum += in.values[g * n_series + s];
      const int h1 = L.HeightPx(cum);
      if (h1 > h0) image.FillRect(L.bar_x0_px[g], bottom - h1 + 1, L.bar_x1_px[g], bottom - h0, legend[s].colour);
    }
    const int bar_top = bottom - L.HeightPx(cum) + 1;
    const int centre = (L.bar_x0_px[g] + L.bar_x1_px[g]) / 2;
    const std::string value = FormatValue(in.value_format, cum);
    image.DrawText(centre - TextW(value) / 2, bar_top - 4 - kTextH, value, kChartInk, kTextScale);
    const int slot_w = L.plot_width_px / static_cast<int>(in.groups.size());
    const int scale = TextW(in.groups[g]) <= slot_w - 4 ? kTextScale : 1;
    image.DrawText(centre - RgbImage::TextWidth(in.groups[g], scale) / 2, bottom + 2 + kTickLen + 4, in.groups[g],
                   kChartInk, scale);
  }
  image.FillRect(x0 - 1, y0, x0 - 1, bottom + 1, kChartInk);
  image.FillRect(x0 - 1, bottom + 1, x1, bottom + 1, kChartInk);
  image.DrawTextUp(kPad, y0 + (L.plot_height_px - TextW(in.value_label)) / 2, in.value_label, kChartInk, kTextScale);
  DrawTitle(&image, in.title);
  DrawLegend(&image, legend, kPad, TitleAreaH(in.title), in.width_px - 2 * kPad);
  return image;
}

double StackedSeriesLayout::TimeAtColumn(int x) const noexcept {
  return time_min_s + (static_cast<double>(x - plot_x_px) + 0.5) / static_cast<double>(plot_width_px) *
                          (time_max_s - time_min_s);
}

int StackedSeriesLayout::HeightPx(double value) const noexcept {
  const double f = value / axis_max;
  if (!(f > 0.0)) return 0;
  return Round(std::min(f, 1.0) * plot_height_px);
}

namespace {

std::vector<LegendEntry> SeriesLegend(const StackedSeriesInput& in) {
  return SeriesLegendOf(in.series, in.series_colours);
}

double SampleTotal(const StackedSeriesInput& in, std::size_t i) {
  double total = 0.0;
  for (std::size_t s = 0; s < in.series.size(); ++s) total += in.values[i * in.series.size() + s];
  return total;
}

}  // namespace

Result<StackedSeriesLayout> LayoutStackedSeries(const StackedSeriesInput& in) {
  if (Status size = CheckImageSize("stacked series", in.width_px, in.height_px); !size.ok()) return size;
  if (Status shape = CheckStackShape("stacked series", "sample", in.times_s.size(), in.series.size(),
                                     in.values.size(), in.series_colours.size());
      !shape.ok()) {
    return shape;
  }
  for (std::size_t i = 0; i < in.times_s.size(); ++i) {
    if (!std::isfinite(in.times_s[i]) || (i > 0 && in.times_s[i] < in.times_s[i - 1])) {
      return InvalidArgument("stacked series: time " + FormatNumber(in.times_s[i], kChartDigits) + " of sample " +
                             std::to_string(i) + " is not finite or before the sample before it");
    }
  }
  for (std::size_t i = 0; i < in.values.size(); ++i) {
    if (!std::isfinite(in.values[i]) || in.values[i] < 0.0) {
      return InvalidArgument("stacked series: value " + FormatNumber(in.values[i], kChartDigits) + " of series '" +
                             in.series[i % in.series.size()] + "' at sample " +
                             std::to_string(i / in.series.size()) + " is not a finite value >= 0");
    }
  }
  StackedSeriesLayout L;
  L.image_width_px = in.width_px;
  L.image_height_px = in.height_px;
  L.time_min_s = std::min(0.0, in.times_s.front());
  L.time_max_s = in.times_s.back() > L.time_min_s ? in.times_s.back() : L.time_min_s + 1.0;
  double top = 0.0;
  for (std::size_t i = 0; i < in.times_s.size(); ++i) top = std::max(top, SampleTotal(in, i));
  if (!(top > 0.0)) top = 1.0;
  const double step = NiceStepAtLeast(top / 8.0);
  L.axis_max = std::ceil(top / step - 1e-9) * step;
  const int legend_h = LegendH(SeriesLegend(in), in.width_px - 2 * kPad);
  L.plot_x_px = kPad + kTextH + 8 + CharsW(9) + 4 + kTickLen + 1;
  L.plot_y_px = TitleAreaH(in.title) + legend_h + kPad;
  L.plot_width_px = in.width_px - L.plot_x_px - 2 * kPad - CharsW(3);
  L.plot_height_px = in.height_px - L.plot_y_px - (2 + kTickLen + 4 + kTextH + 6 + kTextH + kPad);
  if (L.plot_width_px < 16 || L.plot_height_px < 16) {
    return InvalidArgument("stacked series: image " + std::to_string(in.width_px) + " x " +
                           std::to_string(in.height_px) + " px leaves no room for the plot after the title, legend "
                           "and labels");
  }
  return L;
}

Result<RgbImage> RenderStackedSeries(const StackedSeriesInput& in) {
  auto laid = LayoutStackedSeries(in);
  if (!laid.ok()) return laid.status();
  const StackedSeriesLayout& L = *laid;
  auto created = RgbImage::Create(L.image_width_px, L.image_height_px, in.background);
  if (!created.ok()) return created.status();
  RgbImage image = std::move(*created);
  const int x0 = L.plot_x_px, x1 = x0 + L.plot_width_px - 1;
  const int y0 = L.plot_y_px, bottom = y0 + L.plot_height_px - 1;
  const double value_step = NiceStepAtLeast(L.axis_max / 8.0);
  for (double k = 0.0; k * value_step <= L.axis_max * 1.000001; k += 1.0) {
    const int y = bottom - L.HeightPx(k * value_step) + 1;
    if (y <= bottom) image.FillRect(x0, y, x1, y, kGridColour);
    image.FillRect(x0 - 1 - kTickLen, y, x0 - 2, y, kChartInk);
    const std::string label = FormatTickValue(in.value_format, k * value_step);
    image.DrawText(x0 - 2 - kTickLen - 4 - TextW(label), y - kTextH / 2, label, kChartInk, kTextScale);
  }
  const double span_s = L.time_max_s - L.time_min_s;
  const double time_step = NiceStepAtLeast(span_s / 8.0);
  for (double t = std::ceil(L.time_min_s / time_step) * time_step; t <= L.time_max_s * 1.000001; t += time_step) {
    const int x = x0 + Round((t - L.time_min_s) / span_s * L.plot_width_px - 0.5);
    image.FillRect(x, bottom + 2, x, bottom + 1 + kTickLen, kChartInk);
    const std::string label = FormatTick(t, time_step);
    image.DrawText(x - TextW(label) / 2, bottom + 2 + kTickLen + 4, label, kChartInk, kTextScale);
  }
  const std::vector<LegendEntry> legend = SeriesLegend(in);
  const std::size_t n_series = in.series.size();
  std::size_t i = 0;  // the last sample at or before the column's time
  for (int x = x0; x <= x1; ++x) {
    const double t = L.TimeAtColumn(x);
    while (i + 1 < in.times_s.size() && in.times_s[i + 1] <= t) ++i;
    if (in.times_s[i] > t) continue;  // before the first sample: nothing yet
    double cum = 0.0;
    for (std::size_t s = 0; s < n_series; ++s) {
      const int h0 = L.HeightPx(cum);
      cum += in.values[i * n_series + s];
      const int h1 = L.HeightPx(cum);
      if (h1 > h0) image.FillRect(x, bottom - h1 + 1, x, bottom - h0, legend[s].colour);
    }
  }
  for (const double m : in.marks_s) {
    if (!std::isfinite(m) || m < L.time_min_s || m > L.time_max_s) continue;
    const int x = x0 + std::min(L.plot_width_px - 1, static_cast<int>((m - L.time_min_s) / span_s * L.plot_width_px));
    for (int y = y0; y <= bottom; ++y) {  // dotted, over the background only: the bands stay whole
      const Rgb c = image.At(x, y);
      if (y % 4 < 2 && (c == in.background || c == kGridColour)) image.SetPixel(x, y, kFrameColour);
    }
  }
  image.FillRect(x0 - 1, y0, x0 - 1, bottom + 1, kChartInk);
  image.FillRect(x0 - 1, bottom + 1, x1, bottom + 1, kChartInk);
  image.DrawTextUp(kPad, y0 + (L.plot_height_px - TextW(in.value_label)) / 2, in.value_label, kChartInk, kTextScale);
  image.DrawText(x0 + (L.plot_width_px - TextW(in.time_label)) / 2, bottom + 2 + kTickLen + 4 + kTextH + 6,
                 in.time_label, kChartInk, kTextScale);
  DrawTitle(&image, in.title);
  DrawLegend(&image, legend, kPad, TitleAreaH(in.title), in.width_px - 2 * kPad);
  return image;
}

}  // namespace commerge::platform
