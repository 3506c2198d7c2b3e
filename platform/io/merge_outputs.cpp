// SPDX-License-Identifier: BSD-3-Clause
#include "platform/io/merge_outputs.hpp"

#include <cstdio>

#include "platform/io/pcd.hpp"
#include "platform/io/ply.hpp"
#include "platform/io/poses.hpp"

namespace commerge::platform {

namespace {

void PrintMatrix(std::FILE* f, const Eigen::Isometry3d& T) {
  const Eigen::Matrix4d M = T.matrix();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) std::fprintf(f, " %.9g", M(r, c));
  }
  std::fprintf(f, "\n");
}

}  // namespace

Status WriteTransforms(const std::string& path, const MergeResultMessage& m, const std::string& producer) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) return IoError("cannot write " + path);
  std::fprintf(f, "# %s: merge result of round %d\n", producer.c_str(), m.round);
  std::fprintf(f, "# robot <id> merged|unmerged <T_world_map, row-major 3x4> (world = robot 0's map frame)\n");
  for (std::size_t i = 0; i < m.robot_ids.size(); ++i) {
    std::fprintf(f, "robot %d %s", m.robot_ids[i], m.in_world[i] ? "merged" : "unmerged");
    PrintMatrix(f, m.T_world_map[i]);
  }
  std::fprintf(f, "# pair <alpha> <beta> merged|unmerged <T_alpha_beta, row-major 3x4> (p_alpha = T p_beta, map frames; "
                  "identity when unmerged), then a comment with the verdict\n");
  for (const MergePairOutcome& p : m.pairs) {
    std::fprintf(f, "pair %d %d %s", p.alpha, p.beta, p.success ? "merged" : "unmerged");
    PrintMatrix(f, p.T_alpha_beta);
    std::fprintf(f, "#   %s; overlap %.3f, %u inliers, scans %u + %u%s\n", p.verdict.c_str(), static_cast<double>(p.overlap),
                 p.inliers, p.alpha_scans, p.beta_scans,
                 p.success ? (p.consistent ? "; consistent with the other pairs" : "; rejected as inconsistent") : "");
  }
  const bool write_ok = std::ferror(f) == 0;
  if (std::fclose(f) != 0 || !write_ok) return IoError("error writing " + path);
  return Status::Ok();
}

Status WriteMergedMap(const std::string& dir, const MergedMapBuilder& map) {
  const Span<const PointXYZI> points(map.points());
  const Span<const std::uint16_t> ids(map.robot_ids());
  if (Status st = WritePcd(dir + "/merged_map.pcd", points, PcdEncoding::kBinary, ids); !st.ok()) return st;
  return WritePly(dir + "/merged_map.ply", points, ids);
}

Status WriteTrajectory(const std::string& dir, const RobotTrajectory& t) {
  if (t.times_s.size() != t.T_map_sensor.size() || (!t.ground_truth.empty() && t.ground_truth.size() != t.T_map_sensor.size())) {
    return InvalidArgument("trajectory of robot " + std::to_string(t.robot) + ": " + std::to_string(t.T_map_sensor.size()) +
                           " poses, " + std::to_string(t.times_s.size()) + " times, " +
                           std::to_string(t.ground_truth.size()) + " ground-truth poses");
  }
  std::vector<StampedPose> estimated, truth;
  for (std::size_t k = 0; k < t.T_map_sensor.size(); ++k) {
    estimated.push_back({t.times_s[k], t.T_world_map * t.T_map_sensor[k]});
    if (!t.ground_truth.empty()) truth.push_back({t.times_s[k], t.ground_truth[k]});
  }
  const std::string base = dir + "/robot_" + std::to_string(t.robot);
  std::remove((base + (t.in_world ? "_own_frame.tum" : "_world.tum")).c_str());  // an earlier round's, if any
  if (Status st = WriteTumPoses(base + (t.in_world ? "_world.tum" : "_own_frame.tum"), Span<const StampedPose>(estimated));
      !st.ok()) {
    return st;
  }
  if (truth.empty()) return Status::Ok();
  return WriteTumPoses(base + "_gt.tum", Span<const StampedPose>(truth));
}

}  // namespace commerge::platform
