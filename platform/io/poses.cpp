// SPDX-License-Identifier: BSD-3-Clause
#include "platform/io/poses.hpp"

#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <string_view>

#include <Eigen/SVD>

#include "platform/io/file_util.hpp"
#include "platform/io/text_io.hpp"

namespace commerge::platform {

namespace {

using io_detail::LineError;

constexpr double kRotationTolerance = 1e-2;    ///< max |R^T R - I| accepted (then re-orthonormalised)
constexpr double kQuaternionTolerance = 1e-2;  ///< max |norm - 1| accepted (then normalised)
constexpr double kMinQuaternionNorm = 1e-6;

/// Which lines without data a format allows.
enum class Skip { kTrailingBlankLines, kBlankAndCommentLines };

bool IsComment(std::string_view line) {
  const std::size_t first = line.find_first_not_of(" \t");
  return first != std::string_view::npos && line[first] == '#';
}

/// Calls `parse(line, line_number)` for each line that carries data.
template <class ParseLine>
Status ForEachDataLine(const std::string& path, const std::string& text, Skip skip, ParseLine parse) {
  io_detail::LineCursor lines(text);
  std::string_view line;
  std::size_t first_blank_line = 0;
  while (lines.Next(&line)) {
    const bool blank = io_detail::IsBlank(line);
    if (skip == Skip::kBlankAndCommentLines && (blank || IsComment(line))) continue;
    if (blank) {
      if (first_blank_line == 0) first_blank_line = lines.line_number();
      continue;
    }
    if (first_blank_line != 0) {
      return DataLoss(
          LineError(path, first_blank_line, "blank line before more data (only trailing blank lines are allowed)"));
    }
    if (Status s = parse(line, lines.line_number()); !s.ok()) return s;
  }
  return Status::Ok();
}

/// Exactly `n` finite numbers from `line` into `values`.
Status ParseValues(const std::string& path, std::size_t line_number, std::string_view line, std::size_t n,
                   double* values) {
  std::vector<std::string_view> tokens;
  io_detail::SplitTokens(line, &tokens);
  if (tokens.size() != n) {
    return DataLoss(LineError(path, line_number, io_detail::WrongValueCount(n, tokens.size())));
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!io_detail::ParseNumber(tokens[i], &values[i])) {
      return DataLoss(LineError(path, line_number, io_detail::NotANumber(i, tokens[i])));
    }
    if (!std::isfinite(values[i])) {
      return DataLoss(LineError(path, line_number, "value " + std::to_string(i + 1) + " is " +
                                                       std::string(tokens[i]) + "; NaN and inf are not allowed"));
    }
  }
  return Status::Ok();
}

std::string Brief(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.3g", value);
  return text;
}

/// The rotation nearest to `R` (SVD), when `R` is orthonormal within kRotationTolerance and det R > 0.
Result<Eigen::Matrix3d> ProperRotation(const std::string& path, std::size_t line_number, const Eigen::Matrix3d& R) {
  const double error = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  const double det = R.determinant();
  if (!(error <= kRotationTolerance) || !(det > 0.0)) {
    return DataLoss(LineError(path, line_number, "rotation is not orthonormal: max |R^T R - I| = " + Brief(error) +
                                                     ", det R = " + Brief(det) + " (need <= 1e-2 and det > 0)"));
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return Eigen::Matrix3d(svd.matrixU() * svd.matrixV().transpose());
}

Result<Eigen::Isometry3d> ParseKittiPose(const std::string& path, std::size_t line_number, std::string_view line) {
  double v[12];
  if (Status s = ParseValues(path, line_number, line, 12, v); !s.ok()) return s;
  Eigen::Matrix3d R;
  R << v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10];
  auto rotation = ProperRotation(path, line_number, R);
  if (!rotation.ok()) return rotation.status();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = *rotation;
  T.translation() = Eigen::Vector3d(v[3], v[7], v[11]);
  return T;
}

Result<StampedPose> ParseTumPose(const std::string& path, std::size_t line_number, std::string_view line) {
  double v[8];
  if (Status s = ParseValues(path, line_number, line, 8, v); !s.ok()) return s;
  const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);  // w, x, y, z
  const double norm = q.norm();
  if (norm < kMinQuaternionNorm || std::abs(norm - 1.0) > kQuaternionTolerance) {
    return DataLoss(LineError(path, line_number, "quaternion norm " + Brief(norm) + " is not 1 (tolerance 1e-2)"));
  }
  StampedPose pose;
  pose.time_s = v[0];
  pose.T_frame_sensor.linear() = q.normalized().toRotationMatrix();
  pose.T_frame_sensor.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
  return pose;
}

/// Appends `values` separated by spaces and ended by a line break.
void AppendLine(std::string* text, std::initializer_list<double> values) {
  for (const double value : values) {
    io_detail::AppendNumber(text, value);
    *text += ' ';
  }
  text->back() = '\n';
}

Status NonFinitePose(const std::string& path, std::size_t index) {
  return InvalidArgument(path + ": pose " + std::to_string(index) + " has a NaN or inf entry");
}

}  // namespace

Result<std::vector<Eigen::Isometry3d>> ReadKittiPoses(const std::string& path) {
  auto text = ReadTextFile(path);
  if (!text.ok()) return text.status();
  std::vector<Eigen::Isometry3d> poses;
  Status s = ForEachDataLine(path, *text, Skip::kTrailingBlankLines, [&](std::string_view line, std::size_t n) {
    auto pose = ParseKittiPose(path, n, line);
    if (pose.ok()) poses.push_back(*pose);
    return pose.status();
  });
  if (!s.ok()) return s;
  return poses;
}

Status WriteKittiPoses(const std::string& path, Span<const Eigen::Isometry3d> poses) {
  std::string text;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Eigen::Matrix4d& M = poses[i].matrix();
    if (!M.allFinite()) return NonFinitePose(path, i);
    AppendLine(&text, {M(0, 0), M(0, 1), M(0, 2), M(0, 3), M(1, 0), M(1, 1), M(1, 2), M(1, 3), M(2, 0), M(2, 1),
                       M(2, 2), M(2, 3)});
  }
  return io_detail::WriteTextFile(path, text);
}

Result<std::vector<StampedPose>> ReadTumPoses(const std::string& path) {
  auto text = ReadTextFile(path);
  if (!text.ok()) return text.status();
  std::vector<StampedPose> poses;
  Status s = ForEachDataLine(path, *text, Skip::kBlankAndCommentLines, [&](std::string_view line, std::size_t n) {
    auto pose = ParseTumPose(path, n, line);
    if (pose.ok()) poses.push_back(*pose);
    return pose.status();
  });
  if (!s.ok()) return s;
  return poses;
}

Status WriteTumPoses(const std::string& path, Span<const StampedPose> poses) {
  std::string text = "# timestamp tx ty tz qx qy qz qw\n";
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Eigen::Isometry3d& T = poses[i].T_frame_sensor;
    if (!T.matrix().allFinite() || !std::isfinite(poses[i].time_s)) return NonFinitePose(path, i);
    const Eigen::Quaterniond q(T.linear());
    const Eigen::Vector3d t = T.translation();
    AppendLine(&text, {poses[i].time_s, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()});
  }
  return io_detail::WriteTextFile(path, text);
}

Result<std::vector<double>> ReadTimes(const std::string& path) {
  auto text = ReadTextFile(path);
  if (!text.ok()) return text.status();
  std::vector<double> times;
  Status s = ForEachDataLine(path, *text, Skip::kTrailingBlankLines, [&](std::string_view line, std::size_t n) {
    double time = 0.0;
    Status parsed = ParseValues(path, n, line, 1, &time);
    if (parsed.ok()) times.push_back(time);
    return parsed;
  });
  if (!s.ok()) return s;
  return times;
}

}  // namespace commerge::platform
