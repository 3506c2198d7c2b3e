// SPDX-License-Identifier: BSD-3-Clause
// Report charts: cell colours and MIN pooling of the heatmap against a brute force, overlays, equal axis
// scaling of the metric plots measured on the drawn pixels, stacked bar heights and order.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/common/float_limits.hpp"
#include "platform/report/report_charts.hpp"

namespace commerge::platform {
namespace {


struct Box {
  int x0 = std::numeric_limits<int>::max();
  int y0 = std::numeric_limits<int>::max();
  int x1 = -1;
  int y1 = -1;
  int count = 0;
  void Add(int x, int y) {
    x0 = std::min(x0, x);
    y0 = std::min(y0, y);
    x1 = std::max(x1, x);
    y1 = std::max(y1, y);
    ++count;
  }
};

/// Pixels of `colour` inside the rectangle [x0, x1] x [y0, y1].
Box FindColour(const RgbImage& image, Rgb colour, int x0, int y0, int x1, int y1) {
  Box box;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x)
      if (image.At(x, y) == colour) box.Add(x, y);
  return box;
}

Box FindInPlot(const RgbImage& image, const MetricLayout& L, Rgb colour) {
  return FindColour(image, colour, L.plot_x_px, L.plot_y_px, L.plot_x_px + L.plot_width_px - 1,
                    L.plot_y_px + L.plot_height_px - 1);
}

// ------------------------------------------------------------------------------------------ colours

TEST_CASE("ColourMap runs from dark purple to yellow with rising brightness") {
  CHECK(ColourMap(0.0f) == Rgb{68, 1, 84});
  CHECK(ColourMap(1.0f) == Rgb{253, 231, 37});
  CHECK(ColourMap(-3.0f) == ColourMap(0.0f));
  CHECK(ColourMap(7.0f) == ColourMap(1.0f));
  CHECK(ColourMap(kFloatNaN) == kNoValueColour);
  double previous = -1.0;
  for (int i = 0; i <= 100; ++i) {
    const Rgb c = ColourMap(static_cast<float>(i) / 100.0f);
    const double luma = 0.299 * c.r + 0.587 * c.g + 0.114 * c.b;
    CAPTURE(i);
    CHECK(luma >= previous - 0.5);  // perceptual maps get lighter monotonically
    previous = luma;
  }
}

TEST_CASE("HumanBytes and FormatNumber write short readable values") {
  CHECK(HumanBytes(0.0) == "0 B");
  CHECK(HumanBytes(999.0) == "999 B");
  CHECK(HumanBytes(1000.0) == "1.0 kB");
  CHECK(HumanBytes(1.3e6) == "1.3 MB");
  CHECK(HumanBytes(12.44e6) == "12.4 MB");
  CHECK(HumanBytes(134e6) == "134 MB");
  CHECK(HumanBytes(999.7e3) == "1.0 MB");
  CHECK(HumanBytes(2.5e12) == "2.5 TB");
  CHECK(HumanBytes(-1.0) == "?");
  CHECK(HumanBytes(std::nan("")) == "?");
  CHECK(FormatNumber(0.125, kChartDigits) == "0.125");
  CHECK(FormatNumber(42.0, kChartDigits) == "42");
  CHECK(FormatNumber(1.5e6, kChartDigits) == "1.5e+06");
}

// ------------------------------------------------------------------------------------------ heatmap

TEST_CASE("heatmap cells show the colour map, vmin the first colour, NaN the no-value colour") {
  HeatmapInput in;
  in.rows = 4;
  in.cols = 3;
  in.vmin = 2.0f;
  in.vmax = 6.0f;
  in.max_grid_px = 90;  // 3 columns of 30 px, 4 rows of 22 px
  in.values = {2.0f, 3.0f, 4.0f,  //
               5.0f, 6.0f, 9.0f,  //
               1.0f, 2.5f, -7.0f,  //
               kFloatNaN, 4.0f, 5.5f};
  in.title = "similarity";
  in.row_label = "robot beta keyframe";
  in.col_label = "robot alpha keyframe";
  const auto layout = LayoutHeatmap(in);
  REQUIRE(layout.ok());
  CHECK(layout->grid_width_px == 90);
  CHECK(layout->grid_height_px == 88);
  const auto image = RenderHeatmap(in);
  REQUIRE(image.ok());
  CHECK(image->width() == layout->image_width_px);
  CHECK(image->height() == layout->image_height_px);
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 3; ++c) {
      const float v = in.values[static_cast<std::size_t>(r * 3 + c)];
      Rgb expected = kNoValueColour;
      if (!std::isnan(v)) expected = ColourMap((std::clamp(v, 2.0f, 6.0f) - 2.0f) / 4.0f);
      int wrong = 0;
      for (int y = r * 22; y < (r + 1) * 22; ++y)
        for (int x = c * 30; x < (c + 1) * 30; ++x)
          wrong += image->At(layout->grid_x_px + x, layout->grid_y_px + y) != expected;
      CAPTURE(r);
      CAPTURE(c);
      CHECK(wrong == 0);
    }
  }
  // vmin and everything below it: the first colour map colour; vmax and above: the last.
  CHECK(image->At(layout->grid_x_px + 5, layout->grid_y_px + 5) == Rgb{68, 1, 84});
  CHECK(image->At(layout->grid_x_px + 65, layout->grid_y_px + 50) == Rgb{68, 1, 84});
  CHECK(image->At(layout->grid_x_px + 65, layout->grid_y_px + 30) == Rgb{253, 231, 37});
  // The colour bar: vmax colour at the grid's top row, vmin colour at its bottom row.
  const int bar_x = layout->colour_bar_x_px + layout->colour_bar_width_px / 2;
  CHECK(image->At(bar_x, layout->grid_y_px) == Rgb{253, 231, 37});
  CHECK(image->At(bar_x, layout->grid_y_px + 87) == Rgb{68, 1, 84});
}

TEST_CASE("heatmap rectangle ring and marks are drawn over the cells") {
  HeatmapInput in;
  in.rows = 5;
  in.cols = 6;
  in.max_grid_px = 60;  // 10 x 12 px cells
  in.values.assign(30, 0.5f);
  in.rects.push_back(HeatmapRect{1, 2, 3, 4, Rgb{255, 0, 0}, 2});
  in.marks.push_back(HeatmapMark{0, 5, Rgb{255, 255, 255}});
  in.mark_radius_px = 3.0f;
  const auto layout = LayoutHeatmap(in);
  REQUIRE(layout.ok());
  const auto image = RenderHeatmap(in);
  REQUIRE(image.ok());
  const int gx = layout->grid_x_px, gy = layout->grid_y_px;
  // Cells rows 1..3 (y 12..47), cols 2..4 (x 20..49); ring of 2 px just outside.
  const int x0 = gx + 20, x1 = gx + 49, y0 = gy + 12, y1 = gy + 47;
  const Rgb cell = ColourMap(0.5f);
  int ring_wrong = 0, inside_wrong = 0;
  for (int y = y0 - 2; y <= y1 + 2; ++y) {
    for (int x = x0 - 2; x <= x1 + 2; ++x) {
      const bool inside = x >= x0 && x <= x1 && y >= y0 && y <= y1;
      if (inside) {
        inside_wrong += image->At(x, y) != cell;
      } else {
        ring_wrong += image->At(x, y) != Rgb{255, 0, 0};
      }
    }
  }
  CHECK(ring_wrong == 0);
  CHECK(inside_wrong == 0);
  CHECK(image->At(x0 - 3, y0 + 5) == cell);  // nothing beyond the ring
  // Mark at cell (0, 5) (pixels x 50..59, y 0..11): a disc of radius 3 around (55, 6), a dark rim at 4.
  CHECK(image->At(gx + 55, gy + 6) == Rgb{255, 255, 255});
  CHECK(image->At(gx + 58, gy + 6) == Rgb{255, 255, 255});
  CHECK(image->At(gx + 55, gy + 3) == Rgb{255, 255, 255});
  CHECK(image->At(gx + 59, gy + 6) == kChartInk);
  CHECK(image->At(gx + 51, gy + 6) == kChartInk);
  CHECK(image->At(gx + 50, gy + 6) == cell);
}

/// Brute force: pixel p of an axis with n cells drawn over P pixels shows cells [p n / P, (p + 1) n / P).
void CheckPooling(int rows, int cols, int max_px, unsigned seed) {
  CAPTURE(rows);
  CAPTURE(cols);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> value(0.0f, 10.0f);
  HeatmapInput in;
  in.rows = rows;
  in.cols = cols;
  in.max_grid_px = max_px;
  in.vmin = 1.0f;
  in.vmax = 9.0f;
  in.values.resize(static_cast<std::size_t>(rows * cols));
  for (float& v : in.values) v = rng() % 7 == 0 ? kFloatNaN : value(rng);
  for (int c = 0; c < cols; ++c) in.values[static_cast<std::size_t>(3 * cols + c)] = kFloatNaN;  // a NaN row
  const auto layout = LayoutHeatmap(in);
  REQUIRE(layout.ok());
  const auto image = RenderHeatmap(in);
  REQUIRE(image.ok());
  const int px_w = cols <= max_px ? cols * (max_px / cols) : max_px;
  const int px_h = rows <= max_px ? rows * (max_px / rows) : max_px;
  REQUIRE(layout->grid_width_px == px_w);
  REQUIRE(layout->grid_height_px == px_h);
  int wrong = 0;
  for (int py = 0; py < px_h; ++py) {
    const int r0 = py * rows / px_h, r1 = std::max((py + 1) * rows / px_h, r0 + 1);
    for (int px = 0; px < px_w; ++px) {
      const int c0 = px * cols / px_w, c1 = std::max((px + 1) * cols / px_w, c0 + 1);
      float best = std::numeric_limits<float>::infinity();
      bool any = false;
      for (int r = r0; r < r1; ++r) {
        for (int c = c0; c < c1; ++c) {
          const float v = in.values[static_cast<std::size_t>(r * cols + c)];
          if (std::isnan(v)) continue;
          any = true;
          best = std::min(best, v);
        }
      }
      const Rgb expected = any ? ColourMap((best - 1.0f) / 8.0f) : kNoValueColour;
      wrong += image->At(layout->grid_x_px + px, layout->grid_y_px + py) != expected;
    }
  }
  CHECK(wrong == 0);
}

TEST_CASE("heatmap MIN pooling matches a brute force when the grid is larger than the picture") {
  CheckPooling(157, 233, 50, 1);  // both axes pooled
  CheckPooling(20, 301, 60, 2);   // rows enlarged (3 px), columns pooled
  CheckPooling(61, 60, 60, 3);    // one cell over: pooled by pairs and singles
}

TEST_CASE("heatmap picks the value range itself when vmax is not above vmin") {
  HeatmapInput in;
  in.rows = 1;
  in.cols = 3;
  in.max_grid_px = 30;
  in.values = {-4.0f, kFloatNaN, 12.0f};
  in.vmin = in.vmax = 0.0f;
  const auto layout = LayoutHeatmap(in);
  REQUIRE(layout.ok());
  CHECK(layout->vmin == -4.0f);
  CHECK(layout->vmax == 12.0f);
  const auto image = RenderHeatmap(in);
  REQUIRE(image.ok());
  CHECK(image->At(layout->grid_x_px, layout->grid_y_px) == ColourMap(0.0f));
  CHECK(image->At(layout->grid_x_px + 15, layout->grid_y_px) == kNoValueColour);
  CHECK(image->At(layout->grid_x_px + 29, layout->grid_y_px + 29) == ColourMap(1.0f));
}

TEST_CASE("heatmap refuses inconsistent input with a message naming the problem") {
  HeatmapInput in;
  in.rows = 2;
  in.cols = 3;
  in.values.assign(5, 0.0f);
  auto r = RenderHeatmap(in);
  REQUIRE_FALSE(r.ok());
  CHECK(r.status().code() == StatusCode::kInvalidArgument);
  CHECK(r.status().message().find("5 values") != std::string::npos);
  in.values.assign(6, 0.0f);
  in.rects.push_back(HeatmapRect{0, 0, 2, 1, Rgb{}, 1});
  r = RenderHeatmap(in);
  REQUIRE_FALSE(r.ok());
  CHECK(r.status().message().find("(2, 1)") != std::string::npos);
  in.rects.clear();
  in.marks.push_back(HeatmapMark{0, -1, Rgb{}});
  CHECK_FALSE(RenderHeatmap(in).ok());
  in.marks.clear();
  in.max_grid_px = 0;
  CHECK_FALSE(RenderHeatmap(in).ok());
  in.max_grid_px = 100;
  in.rows = 0;
  CHECK_FALSE(RenderHeatmap(in).ok());
}

// ------------------------------------------------------------------------------------------ top view

TEST_CASE("top view draws each point in its robot colour with the same scale on both axes") {
  const std::vector<PointXYZI> points = {
      {0.0f, 0.0f, 0.0f, 0.0f}, {40.0f, 0.0f, 1.0f, 0.0f}, {0.0f, 20.0f, 2.0f, 0.0f},
      {40.0f, 20.0f, 3.0f, 0.0f}, {20.0f, 10.0f, 0.0f, 0.0f}, {20.0f, 10.0f, 0.0f, 0.0f}};
  const std::vector<std::uint16_t> ids = {0, 1, 2, 3, 0, 4};  // the last point overdraws the one before
  TopViewInput in;
  in.points = points;
  in.robot_ids = ids;
  in.robot_names = {"alpha", "beta", "gamma", "delta", "epsilon"};
  in.title = "before merging";
  in.width_px = 300;
  in.height_px = 260;
  const auto layout = LayoutTopView(in);
  REQUIRE(layout.ok());
  const auto image = RenderTopView(in);
  REQUIRE(image.ok());
  Box at[5];
  for (int robot = 0; robot < 5; ++robot) {
    at[robot] = FindInPlot(*image, *layout, RobotColour(robot));
    CAPTURE(robot);
    REQUIRE(at[robot].count == 1);  // one pixel per point (robot 0's second point is overdrawn)
  }
  CHECK(at[4].x0 == static_cast<int>(std::lround(layout->PixelX(20.0))));
  CHECK(at[4].y0 == static_cast<int>(std::lround(layout->PixelY(10.0))));
  // Measured on the picture: 40 m across and 20 m up give the same pixels per metre (within rounding).
  const double per_m_x = (at[1].x0 - at[0].x0) / 40.0;
  const double per_m_y = (at[0].y0 - at[2].y0) / 20.0;  // y grows upwards
  CHECK(per_m_x > 3.0);
  CHECK(std::fabs(per_m_x - per_m_y) <= 1.0 / 40.0 + 1.0 / 20.0 + 1e-9);  // 1 px rounding each
  CHECK(at[3].x0 == at[1].x0);
  CHECK(at[3].y0 == at[2].y0);
  CHECK(at[2].x0 == at[0].x0);
  // The wider extent (x, 40 m) nearly fills the plot's width.
  CHECK(at[1].x0 - at[0].x0 >= static_cast<int>(0.9 * layout->plot_width_px));
}

TEST_CASE("top view bounds override drops points outside and skips non-finite points") {
  const std::vector<PointXYZI> points = {{5.0f, 5.0f, 0.0f, 0.0f},
                                         {50.0f, 50.0f, 0.0f, 0.0f},
                                         {-0.5f, 3.0f, 0.0f, 0.0f},
                                         {kFloatNaN, 1.0f, 0.0f, 0.0f},
                                         {1.0f, std::numeric_limits<float>::infinity(), 0.0f, 0.0f}};
  const std::vector<std::uint16_t> ids = {2, 5, 5, 6, 6};
  TopViewInput in;
  in.points = points;
  in.robot_ids = ids;
  in.robot_names = {"a", "b", "c"};  // legend colours 0..2 only
  in.use_bounds = true;
  in.bounds = BoundsM{0.0f, 0.0f, 10.0f, 10.0f};
  in.width_px = 200;
  in.height_px = 200;
  const auto layout = LayoutTopView(in);
  REQUIRE(layout.ok());
  CHECK(layout->PixelX(5.0) == doctest::Approx(layout->plot_x_px + (layout->plot_width_px - 1) / 2.0));
  const auto image = RenderTopView(in);
  REQUIRE(image.ok());
  const Box inside = FindInPlot(*image, *layout, RobotColour(2));
  REQUIRE(inside.count == 1);
  CHECK(inside.x0 == static_cast<int>(std::lround(layout->PixelX(5.0))));
  const Box outside = FindColour(*image, RobotColour(5), 0, 0, image->width() - 1, image->height() - 1);
  const Box skipped = FindColour(*image, RobotColour(6), 0, 0, image->width() - 1, image->height() - 1);
  CHECK(skipped.count == 0);
  // (-0.5, 3) lies left of the bounds but inside the square plot (the plot is wider than 10 m only
  // when the image is not square); it is drawn exactly when its pixel is inside the plot.
  const int ox = static_cast<int>(std::lround(layout->PixelX(-0.5)));
  CHECK(outside.count == (ox >= layout->plot_x_px ? 1 : 0));

  const std::vector<std::uint16_t> too_few = {1};
  in.robot_ids = too_few;
  const auto bad = RenderTopView(in);
  REQUIRE_FALSE(bad.ok());
  CHECK(bad.status().message().find("1 robot ids for 5 points") != std::string::npos);
  in.robot_ids = ids;
  in.bounds = BoundsM{0.0f, 0.0f, 0.0f, 10.0f};
  CHECK_FALSE(RenderTopView(in).ok());
  in.use_bounds = false;
  in.width_px = 10;
  CHECK(RenderTopView(in).status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("top view keeps metre resolution far from the origin") {
  const std::vector<PointXYZI> points = {{500000.0f, 4000000.0f, 0.0f, 0.0f}, {500100.0f, 4000050.0f, 0.0f, 0.0f}};
  TopViewInput in;
  in.points = points;
  in.width_px = 300;
  in.height_px = 300;
  const auto layout = LayoutTopView(in);
  REQUIRE(layout.ok());
  CHECK(layout->px_per_m * 100.0 >= 0.9 * (layout->plot_width_px - 1) / 1.04);
  const auto image = RenderTopView(in);
  REQUIRE(image.ok());
  const Box both = FindInPlot(*image, *layout, RobotColour(0));
  REQUIRE(both.count == 2);
  CHECK(std::fabs((both.x1 - both.x0) - 100.0 * layout->px_per_m) <= 1.0);  // two roundings
}

TEST_CASE("top view of no points still draws an empty frame") {
  TopViewInput in;
  in.width_px = 200;
  in.height_px = 160;
  const auto image = RenderTopView(in);
  REQUIRE(image.ok());
  CHECK(image->width() == 200);
}

// ------------------------------------------------------------------------------------------ trajectories

TEST_CASE("trajectories: polylines in robot colours, highlighted discs, equal scaling") {
  TrajectoryPlotInput in;
  in.width_px = 320;
  in.height_px = 300;
  in.title = "trajectories";
  TrajectorySeries a, b;
  a.name = "alpha";
  a.robot_index = 0;
  for (int i = 0; i <= 10; ++i) a.path.push_back(PlotPointM{10.0f * static_cast<float>(i), 0.0f});  // 100 m along x
  a.highlighted = {5};
  b.name = "beta";
  b.robot_index = 1;
  for (int i = 0; i <= 5; ++i) b.path.push_back(PlotPointM{-20.0f, 10.0f * static_cast<float>(i)});  // 50 m along y
  b.highlighted = {2};
  in.robots = {a, b};
  in.line_thickness_px = 1;
  in.highlight_radius_px = 4.0f;
  const auto layout = LayoutTrajectories(in);
  REQUIRE(layout.ok());
  const auto image = RenderTrajectories(in);
  REQUIRE(image.ok());
  const Box ba = FindInPlot(*image, *layout, RobotColour(0));
  const Box bb = FindInPlot(*image, *layout, RobotColour(1));
  REQUIRE(ba.count > 0);
  REQUIRE(bb.count > 0);
  // Lengths measured on the picture: 100 m in x and 50 m in y at the same pixels per metre.
  const double per_m_x = (ba.x1 - ba.x0) / 100.0;
  const double per_m_y = (bb.y1 - bb.y0) / 50.0;
  CHECK(per_m_x > 1.0);
  CHECK(std::fabs(per_m_x - per_m_y) <= 1.5 / 50.0);
  // Highlight discs: their centres have the robot colour, their 4 px neighbours too, the rim is dark.
  auto pixel = [](double v) { return static_cast<int>(std::lround(v)); };
  const int hx = pixel(layout->PixelX(50.0)), hy = pixel(layout->PixelY(0.0));
  CHECK(image->At(hx, hy - 4) == RobotColour(0));
  CHECK(image->At(hx, hy + 4) == RobotColour(0));
  CHECK(image->At(hx, hy - 5) == kChartInk);
  const int gx = pixel(layout->PixelX(-20.0)), gy = pixel(layout->PixelY(20.0));
  CHECK(image->At(gx + 4, gy) == RobotColour(1));
  // A line pixel between two positions.
  CHECK(image->At(pixel(layout->PixelX(25.0)), hy) == RobotColour(0));

  in.robots[0].highlighted = {11};
  const auto bad = RenderTrajectories(in);
  REQUIRE_FALSE(bad.ok());
  CHECK(bad.status().message().find("alpha") != std::string::npos);
}

// ------------------------------------------------------------------------------------------ bar chart

/// Colour runs in one column from the bar's foot upwards: (colour, length) until the background.
std::vector<std::pair<Rgb, int>> RunsUp(const RgbImage& image, const BarChartLayout& L, std::size_t g) {
  const int x = (L.bar_x0_px[g] + L.bar_x1_px[g]) / 2;
  std::vector<std::pair<Rgb, int>> runs;
  for (int y = L.plot_y_px + L.plot_height_px - 1; y >= L.plot_y_px; --y) {
    const Rgb c = image.At(x, y);
    if (c == kChartBackground || c == Rgb{225, 225, 225}) break;  // background or a grid line
    if (runs.empty() || runs.back().first != c) runs.push_back({c, 0});
    ++runs.back().second;
  }
  return runs;
}

TEST_CASE("bar chart: stacked heights proportional to the values, series in order") {
  BarChartInput in;
  in.groups = {"send-all", "A", "A+B"};
  in.series = {"descriptors", "poses", "scans"};
  in.values = {100.0, 200.0, 300.0,  //
               50.0, 0.0, 150.0,     //
               400.0, 400.0, 400.0};
  in.series_colours = {Rgb{200, 0, 0}, Rgb{0, 150, 0}, Rgb{0, 0, 200}};
  in.title = "bytes per mode";
  in.value_label = "bytes";
  in.width_px = 360;
  in.height_px = 300;
  const auto layout = LayoutBarChart(in);
  REQUIRE(layout.ok());
  const auto image = RenderBarChart(in);
  REQUIRE(image.ok());
  const double totals[3] = {600.0, 200.0, 1200.0};
  int heights[3] = {0, 0, 0};
  std::vector<std::vector<std::pair<Rgb, int>>> runs;
  for (std::size_t g = 0; g < 3; ++g) {
    runs.push_back(RunsUp(*image, *layout, g));
    for (const auto& run : runs.back()) heights[g] += run.second;
  }
  REQUIRE(heights[2] > 100);
  const double px_per_value = heights[2] / totals[2];
  for (std::size_t g = 0; g < 3; ++g) {
    CAPTURE(g);
    CHECK(std::fabs(heights[g] - totals[g] * px_per_value) <= 1.5);
    std::size_t run = 0;
    for (std::size_t s = 0; s < 3; ++s) {
      const double v = in.values[g * 3 + s];
      if (v == 0.0) continue;  // an empty series leaves no run
      REQUIRE(run < runs[g].size());
      CHECK(runs[g][run].first == in.series_colours[s]);  // bottom to top in series order
      CHECK(std::fabs(runs[g][run].second - v * px_per_value) <= 1.5);
      ++run;
    }
    CHECK(run == runs[g].size());
    // A value label above the bar: dark pixels within the label band over the bar.
    const int top = layout->plot_y_px + layout->plot_height_px - heights[g];
    const Box label =
        FindColour(*image, kChartInk, layout->bar_x0_px[g] - 20, top - 22, layout->bar_x1_px[g] + 20, top - 2);
    CHECK(label.count > 10);
  }
  // Linear axis from 0: the tallest bar against the axis maximum.
  CHECK(layout->axis_min == 0.0);
  CHECK(std::fabs(heights[2] - 1200.0 / layout->axis_max * layout->plot_height_px) <= 1.0);
}

TEST_CASE("bar chart on a log axis: equal ratios make equal steps") {
  BarChartInput in;
  in.groups = {"a", "b", "c", "d"};
  in.series = {"bytes"};
  in.values = {10.0, 100.0, 1000.0, 10000.0};
  in.log_scale = true;
  in.width_px = 300;
  in.height_px = 260;
  const auto layout = LayoutBarChart(in);
  REQUIRE(layout.ok());
  CHECK(layout->axis_min == doctest::Approx(1.0));
  CHECK(layout->axis_max == doctest::Approx(10000.0));
  const auto image = RenderBarChart(in);
  REQUIRE(image.ok());
  int h[4];
  for (std::size_t g = 0; g < 4; ++g) {
    const auto runs = RunsUp(*image, *layout, g);
    REQUIRE(runs.size() == 1);
    CHECK(runs[0].first == RobotColour(0));
    h[g] = runs[0].second;
  }
  CHECK(h[0] > 0);
  CHECK(std::abs((h[1] - h[0]) - h[0]) <= 2);
  CHECK(std::abs((h[2] - h[1]) - h[0]) <= 2);
  CHECK(std::abs((h[3] - h[2]) - h[0]) <= 2);
  CHECK(h[3] == layout->plot_height_px);
}

TEST_CASE("bar chart refuses negative, non-finite and mismatched values") {
  BarChartInput in;
  in.groups = {"a", "b"};
  in.series = {"x"};
  in.values = {1.0, -2.0};
  auto r = RenderBarChart(in);
  REQUIRE_FALSE(r.ok());
  CHECK(r.status().message().find("group 'b'") != std::string::npos);
  in.values = {1.0, std::nan("")};
  CHECK_FALSE(RenderBarChart(in).ok());
  in.values = {1.0};
  CHECK_FALSE(RenderBarChart(in).ok());
  in.values = {1.0, 2.0};
  in.series_colours = {Rgb{}, Rgb{}};
  CHECK_FALSE(RenderBarChart(in).ok());
  in.series_colours.clear();
  in.height_px = 9000;
  CHECK_FALSE(RenderBarChart(in).ok());
  in.height_px = 200;
  in.values = {0.0, 0.0};
  CHECK(RenderBarChart(in).ok());  // all zero: an empty chart, not an error
}

// The colour runs of plot column x from the bottom row up: (colour, length) of each band, background left out.
std::vector<std::pair<Rgb, int>> ColumnRuns(const RgbImage& image, const StackedSeriesLayout& L, int x) {
  std::vector<std::pair<Rgb, int>> runs;
  for (int y = L.plot_y_px + L.plot_height_px - 1; y >= L.plot_y_px; --y) {
    const Rgb c = image.At(x, y);
    if (c == kChartBackground || c == Rgb{225, 225, 225}) continue;  // background, grid lines
    if (!runs.empty() && runs.back().first == c) {
      ++runs.back().second;
    } else {
      runs.emplace_back(c, 1);
    }
  }
  return runs;
}

TEST_CASE("stacked series: each column stacks every series' last sample at or before its time, so jumps stay jumps") {
  StackedSeriesInput in;
  in.times_s = {0.0, 10.0, 20.0, 30.0};
  in.series = {"robot 0", "robot 1"};
  in.values = {100.0, 0.0,     //
               200.0, 0.0,     //
               300.0, 1000.0,  // robot 1's scans arrive at 20 s: a jump
               400.0, 1100.0};
  in.marks_s = {20.0, 99.0};  // the second is outside the axis: not drawn
  in.title = "bytes received";
  in.time_label = "time [s]";
  in.value_label = "bytes";
  in.width_px = 500;
  in.height_px = 320;
  const auto layout = LayoutStackedSeries(in);
  REQUIRE(layout.ok());
  const auto image = RenderStackedSeries(in);
  REQUIRE(image.ok());
  const StackedSeriesLayout& L = *layout;
  CHECK(L.time_min_s == 0.0);
  CHECK(L.time_max_s == 30.0);
  CHECK(L.axis_max >= 1500.0);
  int checked = 0;
  for (int x = L.plot_x_px; x < L.plot_x_px + L.plot_width_px; x += 7) {
    const double t = L.TimeAtColumn(x);
    const std::size_t i = t >= 30.0 ? 3 : t >= 20.0 ? 2 : t >= 10.0 ? 1 : 0;  // the reference step
    const auto runs = ColumnRuns(*image, L, x);
    CAPTURE(x);
    CAPTURE(t);
    const double v0 = in.values[2 * i], v1 = in.values[2 * i + 1];
    REQUIRE(!runs.empty());
    CHECK(runs[0].first == RobotColour(0));  // bottom to top in series order
    CHECK(std::abs(runs[0].second - L.HeightPx(v0)) <= 1);
    if (v1 > 0.0) {
      REQUIRE(runs.size() == 2);
      CHECK(runs[1].first == RobotColour(1));
      CHECK(std::abs(runs[0].second + runs[1].second - L.HeightPx(v0 + v1)) <= 1);
    } else {
      CHECK(runs.size() == 1);
    }
    ++checked;
  }
  CHECK(checked > 40);  // every 7th of the plot's columns
  // The mark: dotted grey pixels in the column of 20 s above the bands.
  const int mark_x = L.plot_x_px + static_cast<int>(20.0 / 30.0 * L.plot_width_px);
  int grey = 0;
  for (int y = L.plot_y_px; y < L.plot_y_px + L.plot_height_px - L.HeightPx(1300.0); ++y) {
    grey += image->At(mark_x, y) == Rgb{120, 120, 120} ? 1 : 0;
  }
  CHECK(grey > 10);
}

TEST_CASE("stacked series refuses unordered times, negative values and mismatched sizes, naming them") {
  StackedSeriesInput in;
  in.times_s = {0.0, 5.0};
  in.series = {"a"};
  in.values = {1.0, 2.0};
  CHECK(RenderStackedSeries(in).ok());
  in.times_s = {5.0, 1.0};
  auto r = RenderStackedSeries(in);
  REQUIRE_FALSE(r.ok());
  CHECK(r.status().message().find("sample 1") != std::string::npos);
  in.times_s = {0.0, 5.0};
  in.values = {1.0, -1.0};
  r = RenderStackedSeries(in);
  REQUIRE_FALSE(r.ok());
  CHECK(r.status().message().find("series 'a' at sample 1") != std::string::npos);
  in.values = {1.0};
  CHECK_FALSE(RenderStackedSeries(in).ok());
  in.values = {1.0, 1.0};
  in.series_colours = {Rgb{}, Rgb{}};
  CHECK_FALSE(RenderStackedSeries(in).ok());
  in.series_colours.clear();
  in.times_s.clear();
  in.values.clear();
  CHECK_FALSE(RenderStackedSeries(in).ok());
  in.times_s = {3.0};  // one sample, all zero: an empty chart
  in.values = {0.0};
  CHECK(RenderStackedSeries(in).ok());
}

}  // namespace
}  // namespace commerge::platform
