// SPDX-License-Identifier: BSD-3-Clause
// The report's charts (heatmap, trajectories, top view, stacked bars) rendered into RgbImages; no file I/O.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/common/number_text.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "platform/report/raster_image.hpp"

namespace commerge::platform {

/// Chart background and text colours shared by every chart.
inline constexpr Rgb kChartBackground{255, 255, 255};
inline constexpr Rgb kChartInk{30, 30, 30};
/// Heatmap cells without a value (NaN).
inline constexpr Rgb kNoValueColour{205, 205, 205};

/// Perceptual colour map from dark purple (t = 0) over blue and green to yellow (t = 1), viridis-like:
/// linear interpolation between 10 anchor colours, the first exactly {68, 1, 84}, the last {253, 231, 37}.
/// t is clamped to [0, 1]; NaN gives kNoValueColour.
Rgb ColourMap(float t) noexcept;

/// "512 B", "1.3 kB", "12.4 MB", "134 MB", "2.0 GB" (SI units, 1 kB = 1000 B); negative or NaN: "?".
std::string HumanBytes(double bytes);
/// Significant digits of the numbers on charts (FormatNumber, core/common/number_text.hpp): "0.125", "42", "1.5e+06".
constexpr int kChartDigits = 3;

// ---------------------------------------------------------------------------------------------- heatmap

/// Cells (row0..row1) x (col0..col1), inclusive, outlined by a ring `thickness_px` wide just outside them.
struct HeatmapRect {
  int row0 = 0;
  int col0 = 0;
  int row1 = 0;
  int col1 = 0;
  Rgb colour{255, 0, 0};
  int thickness_px = 2;
};

/// One cell marked by a dot (a disc with a 1 px dark rim) at its centre.
struct HeatmapMark {
  int row = 0;
  int col = 0;
  Rgb colour{255, 255, 255};
};

struct HeatmapInput {
  int rows = 0;  ///< drawn top to bottom
  int cols = 0;  ///< drawn left to right
  /// rows * cols values, row-major (values[row * cols + col]); NaN = no value (kNoValueColour).
  std::vector<float> values;
  /// Colour map range; values are clamped to it. When !(vmax > vmin) the range of the finite values is used.
  float vmin = 0.0f;
  float vmax = 1.0f;
  /// The grid fits into max_grid_px x max_grid_px (1..4096). An axis of n <= max_grid_px cells draws each
  /// cell max_grid_px / n pixels wide (integer division); a longer axis is drawn max_grid_px pixels long and
  /// pixel p shows the MIN of cells [p * n / max_grid_px, (p + 1) * n / max_grid_px) (low = similar).
  int max_grid_px = 900;
  std::vector<HeatmapRect> rects;  ///< outlined on top of the cells (e.g. the chosen cluster)
  std::vector<HeatmapMark> marks;  ///< dots on top of the rectangles
  float mark_radius_px = 2.5f;
  std::string title;
  std::string row_label;  ///< left axis, e.g. "robot beta keyframe"
  std::string col_label;  ///< bottom axis, e.g. "robot alpha keyframe"
  Rgb background = kChartBackground;
};

/// Where RenderHeatmap puts things (pixels).
struct HeatmapLayout {
  int image_width_px = 0;
  int image_height_px = 0;
  int grid_x_px = 0;  ///< left column of the grid
  int grid_y_px = 0;  ///< top row of the grid
  int grid_width_px = 0;
  int grid_height_px = 0;
  int colour_bar_x_px = 0;  ///< colour bar: vmax at grid_y_px, vmin at the grid's bottom row
  int colour_bar_width_px = 0;
  float vmin = 0.0f;  ///< the range actually used
  float vmax = 1.0f;
};

/// Validates the input (sizes, values count, overlay cells inside the grid) and computes the layout.
Result<HeatmapLayout> LayoutHeatmap(const HeatmapInput& input);
Result<RgbImage> RenderHeatmap(const HeatmapInput& input);

// -------------------------------------------------------------------- metric plots (trajectories, top view)

struct PlotPointM {
  float x_m = 0.0f;
  float y_m = 0.0f;
};

/// Axis-aligned rectangle in the plotted frame [m].
struct BoundsM {
  float min_x_m = 0.0f;
  float min_y_m = 0.0f;
  float max_x_m = 0.0f;
  float max_y_m = 0.0f;
};

/// Where a metric plot puts things: x to the right, y up, the same pixels per metre on both axes.
struct MetricLayout {
  int image_width_px = 0;
  int image_height_px = 0;
  int plot_x_px = 0;  ///< plot area: columns plot_x_px .. plot_x_px + plot_width_px - 1
  int plot_y_px = 0;  ///< rows plot_y_px .. plot_y_px + plot_height_px - 1
  int plot_width_px = 0;
  int plot_height_px = 0;
  double min_x_m = 0.0;  ///< x [m] at the centre of the plot's left column
  double min_y_m = 0.0;  ///< y [m] at the centre of the plot's bottom row
  double px_per_m = 1.0;
  double grid_step_m = 1.0;  ///< spacing of the labelled grid lines

  /// Pixel coordinates (centre at integers) of a position [m]; drawn pixels are these rounded.
  double PixelX(double x_m) const noexcept { return plot_x_px + (x_m - min_x_m) * px_per_m; }
  double PixelY(double y_m) const noexcept { return plot_y_px + plot_height_px - 1 - (y_m - min_y_m) * px_per_m; }
};

struct TrajectorySeries {
  std::string name;     ///< legend text
  int robot_index = 0;  ///< colour RobotColour(robot_index)
  std::vector<PlotPointM> path;  ///< positions [m] in the frame all series share, drawn as a polyline
  std::vector<int> highlighted;  ///< indices into `path` drawn as filled discs (scans selected for exchange)
};

struct TrajectoryPlotInput {
  std::vector<TrajectorySeries> robots;
  std::string title;
  int width_px = 900;   ///< whole image
  int height_px = 900;
  int line_thickness_px = 2;  ///< 1..3
  float highlight_radius_px = 4.0f;
  Rgb background = kChartBackground;
};

/// Validates the input (image size, highlighted indices inside their path) and computes the layout: the
/// finite path points with a 4 % margin, centred.
Result<MetricLayout> LayoutTrajectories(const TrajectoryPlotInput& input);
Result<RgbImage> RenderTrajectories(const TrajectoryPlotInput& input);

struct TopViewInput {
  Span<const PointXYZI> points;  ///< x and y [m] are drawn (1 px each, in order); non-finite points skipped
  Span<const std::uint16_t> robot_ids;  ///< empty (all robot 0) or one per point; colour RobotColour(id)
  /// Legend: entry i is drawn in RobotColour(i); empty: "robot <id>" for every id present (at most 16).
  std::vector<std::string> robot_names;
  bool use_bounds = false;  ///< true: show exactly `bounds` (centred), else the points' extent + 2 %
  BoundsM bounds;
  std::string title;
  int width_px = 900;  ///< whole image
  int height_px = 900;
  Rgb background = kChartBackground;
};

Result<MetricLayout> LayoutTopView(const TopViewInput& input);
Result<RgbImage> RenderTopView(const TopViewInput& input);

// -------------------------------------------------------------------------------------------- bar chart

enum class BarValueFormat {
  kBytes,   ///< HumanBytes ("1.3 MB")
  kNumber,  ///< FormatNumber ("42")
};

/// One stacked bar per group; each bar stacks the series bottom to top in the order given.
struct BarChartInput {
  std::vector<std::string> groups;  ///< e.g. "send-all", "A", "A+B", "A+C", "A+B+C"
  std::vector<std::string> series;  ///< e.g. "descriptors", "poses", "policies", "scans"
  /// groups.size() * series.size() finite values >= 0: values[group * series.size() + series_index].
  std::vector<double> values;
  std::vector<Rgb> series_colours;  ///< empty: RobotColour(series_index); else one per series
  bool log_scale = false;  ///< log10 value axis from a power of ten below the smallest positive value
  BarValueFormat value_format = BarValueFormat::kBytes;
  std::string title;
  std::string value_label;  ///< value axis, e.g. "bytes sent"
  int width_px = 900;  ///< whole image
  int height_px = 600;
  Rgb background = kChartBackground;
};

struct BarChartLayout {
  int image_width_px = 0;
  int image_height_px = 0;
  int plot_x_px = 0;  ///< plot area: columns plot_x_px .. plot_x_px + plot_width_px - 1
  int plot_y_px = 0;  ///< rows plot_y_px .. plot_y_px + plot_height_px - 1; bars stand on the bottom row
  int plot_width_px = 0;
  int plot_height_px = 0;
  std::vector<int> bar_x0_px;  ///< per group, first and last column of its bar
  std::vector<int> bar_x1_px;
  double axis_min = 0.0;  ///< value at the bottom of the plot (log scale: a power of ten; linear: 0)
  double axis_max = 1.0;  ///< value at the top
  bool log_scale = false;

  /// Bar height in pixels for a (stacked) value: round(fraction of the axis * plot_height_px), 0..plot_height_px.
  int HeightPx(double value) const noexcept;
};

Result<BarChartLayout> LayoutBarChart(const BarChartInput& input);
Result<RgbImage> RenderBarChart(const BarChartInput& input);

// ------------------------------------------------------------------------------------- stacked series over time

/// Cumulative series over time stacked as filled bands (e.g. the bytes each robot sent): at time t every series
/// holds the value of its last sample at or before t (a step, so a burst of scans stays a jump); before the first
/// sample, 0. Vertical marks (e.g. the ends of merge rounds) are drawn as dotted lines above the bands.
struct StackedSeriesInput {
  std::vector<double> times_s;      ///< ascending, finite; at least one
  std::vector<std::string> series;  ///< legend names, at least one
  /// times_s.size() * series.size() finite values >= 0: values[sample * series.size() + series_index].
  std::vector<double> values;
  std::vector<Rgb> series_colours;  ///< empty: RobotColour(series_index); else one per series
  std::vector<double> marks_s;      ///< finite times; those outside the time axis are not drawn
  BarValueFormat value_format = BarValueFormat::kBytes;
  std::string title;
  std::string time_label;   ///< e.g. "time since the first message [s]"
  std::string value_label;  ///< e.g. "bytes received"
  int width_px = 900;
  int height_px = 600;
  Rgb background = kChartBackground;
};

struct StackedSeriesLayout {
  int image_width_px = 0;
  int image_height_px = 0;
  int plot_x_px = 0;  ///< plot area: columns plot_x_px .. plot_x_px + plot_width_px - 1
  int plot_y_px = 0;  ///< rows plot_y_px .. plot_y_px + plot_height_px - 1; bands stand on the bottom row
  int plot_width_px = 0;
  int plot_height_px = 0;
  double time_min_s = 0.0;  ///< at the left edge of the plot's first column
  double time_max_s = 1.0;  ///< at the right edge of its last column
  double axis_max = 1.0;    ///< value at the top (the axis starts at 0)

  /// The time at the centre of plot column x.
  double TimeAtColumn(int x) const noexcept;
  /// Band height in pixels of a (stacked) value: round(value / axis_max * plot_height_px), 0..plot_height_px.
  int HeightPx(double value) const noexcept;
};

Result<StackedSeriesLayout> LayoutStackedSeries(const StackedSeriesInput& input);
Result<RgbImage> RenderStackedSeries(const StackedSeriesInput& input);

}  // namespace commerge::platform
