// SPDX-License-Identifier: BSD-3-Clause
#include "core/slam/robot_mapper.hpp"

#include <cmath>
#include <string>

#include "core/geometry/angles.hpp"

namespace commerge {

Status ValidateRobotMapperParams(const RobotMapperParams& p) {
  if (Status s = ValidateKeyframerParams(p.keyframer); !s.ok()) return s;
  if (Status s = ValidateLoopDetectorParams(p.loop); !s.ok()) return s;
  if (!(p.voxel.voxel_size_m > 0.0)) {
    return InvalidArgument("robot mapper: voxel_size_m must be > 0, got " + std::to_string(p.voxel.voxel_size_m));
  }
  if (!(p.odometry_sigma_translation_m > 0.0) || !(p.odometry_sigma_rotation_rad > 0.0)) {
    return InvalidArgument("robot mapper: odometry_sigma_translation_m and odometry_sigma_rotation_rad must be > 0");
  }
  return Status::Ok();
}

RobotMapper::RobotMapper(const RobotMapperParams& params, const RobotMapperCapacity& capacity,
                         PlaceDescriptor* descriptor, ScanStore* store)
    : params_(params),
      capacity_(capacity),
      descriptor_(descriptor),
      store_(store),
      params_status_(ValidateRobotMapperParams(params)),
      keyframer_(params.keyframer),
      db_(*descriptor, capacity.max_keyframes),
      graph_(capacity.max_keyframes, 2 * capacity.max_keyframes),  // odometry + at most one loop per keyframe
      voxel_grid_(capacity.max_points_per_raw_scan),
      graph_distance_(capacity.max_keyframes),
      descriptor_scratch_(descriptor->dimension()) {
  voxels_.reserve(capacity.max_points_per_stored_scan);
  match_points_.reserve(capacity.max_points_per_stored_scan);
  T_odom_keyframes_.reserve(capacity.max_keyframes);
  encoded_.resize(EncodedScanBytes(capacity.max_points_per_stored_scan));
}

std::size_t RobotMapper::scan_workspace_bytes() const {
  return voxel_grid_.workspace_capacity_bytes() + voxels_.capacity() * sizeof(PointXYZI) + encoded_.capacity() +
         descriptor_scratch_.capacity() * sizeof(float);
}

std::size_t RobotMapper::loop_closure_workspace_bytes() const {
  return match_points_.capacity() * sizeof(PointXYZI) + spill_buffer_.capacity() + verifier_.workspace_bytes() +
         graph_distance_.workspace_bytes();
}

Result<KeyframeStep> RobotMapper::AddScan(Span<const PointXYZI> raw_scan, const Eigen::Isometry3d& T_odom_sensor) {
  if (!params_status_.ok()) return params_status_;
  if (raw_scan.size() > capacity_.max_points_per_raw_scan) {
    return InvalidArgument("robot mapper: scan of " + std::to_string(raw_scan.size()) +
                           " points exceeds max_points_per_raw_scan = " +
                           std::to_string(capacity_.max_points_per_raw_scan));
  }
  ++stats_.scans;
  KeyframeStep step;
  if (!keyframer_.Offer(T_odom_sensor)) return step;
  if (graph_.num_nodes() >= graph_.max_nodes()) {
    return ResourceExhausted("robot mapper: keyframe capacity " + std::to_string(graph_.max_nodes()) +
                             " reached (raise --max-keyframes)");
  }
  step.is_keyframe = true;
  step.keyframe = static_cast<std::uint32_t>(graph_.num_nodes());
  ++stats_.keyframes;

  // 2. Descriptor on the raw scan.
  auto info = descriptor_->Compute(raw_scan, Span<float>(descriptor_scratch_));
  if (!info.ok()) return info.status();
  step.descriptor = *info;
  if (!step.descriptor.valid) ++stats_.invalid_descriptors;
  if (Status s = db_.Add(Span<const float>(descriptor_scratch_), step.descriptor.valid); !s.ok()) return s;

  // 3. Voxelised scan into the store.
  auto vox = voxel_grid_.Downsample(raw_scan, params_.voxel, &voxels_);
  if (!vox.ok()) return vox.status();
  step.voxel_points = voxels_.size();
  if (voxels_.size() > capacity_.max_points_per_stored_scan) {
    step.store_status = ResourceExhausted("keyframe " + std::to_string(step.keyframe) + ": voxelised scan has " +
                                          std::to_string(voxels_.size()) + " points, max_points_per_stored_scan = " +
                                          std::to_string(capacity_.max_points_per_stored_scan));
  } else {
    auto enc = EncodeScan(Span<const PointXYZI>(voxels_), Span<std::uint8_t>(encoded_));
    if (!enc.ok()) {
      step.store_status = enc.status();
    } else {
      step.encoded_bytes = enc->bytes_written;
      auto put = store_->Put(step.keyframe, Span<const std::uint8_t>(encoded_.data(), enc->bytes_written));
      if (put.ok()) {
        step.store = *put;
      } else {
        step.store_status = put.status();
      }
    }
  }
  if (!step.store_status.ok()) ++stats_.scans_not_stored;

  // 4. Pose-graph node and odometry edge.
  if (step.keyframe == 0) {
    if (Status s = graph_.AddNode(Eigen::Isometry3d::Identity()); !s.ok()) return s;
    T_odom_keyframes_.push_back(T_odom_sensor);  // one per graph node; reserved (capacity checked above)
  } else {
    PoseGraphEdge odom;
    odom.from = step.keyframe - 1;
    odom.to = step.keyframe;
    odom.T_from_to = T_odom_last_keyframe_.inverse() * T_odom_sensor;
    odom.information.setZero();
    const double wt = 1.0 / (params_.odometry_sigma_translation_m * params_.odometry_sigma_translation_m);
    const double wr = 1.0 / (params_.odometry_sigma_rotation_rad * params_.odometry_sigma_rotation_rad);
    odom.information.diagonal() << wt, wt, wt, wr, wr, wr;
    odom.kind = EdgeKind::kOdometry;
    if (Status s = graph_.AddNode(graph_.pose(odom.from) * odom.T_from_to); !s.ok()) return s;
    T_odom_keyframes_.push_back(T_odom_sensor);
    if (Status s = graph_.AddEdge(odom); !s.ok()) return s;
  }
  T_odom_last_keyframe_ = T_odom_sensor;

  // 5. Intra-robot loop closure.
  if (step.descriptor.valid && step.store_status.ok()) {
    if (Status s = FindLoop(step.keyframe, Span<const float>(descriptor_scratch_), &step); !s.ok()) return s;
  }
  return step;
}

Status RobotMapper::FindLoop(std::uint32_t query, Span<const float> query_descriptor, KeyframeStep* step) {
  const std::uint32_t window = params_.loop.window_keyframes;
  // T_a = {phi | phi <= a - tau_window} (paper, 1-based); 0-based: candidates k < a - tau_window + 1.
  if (query + 1 <= window) return Status::Ok();
  const std::size_t end = query - window + 1;
  const DescriptorDatabase::Match m = db_.NearestBefore(query_descriptor, end);
  if (!m.found) return Status::Ok();
  if (m.distance > params_.loop.max_descriptor_distance) {
    step->loop.verdict = LoopVerdict::kDescriptorTooFar;
    step->loop.loop.query = query;
    step->loop.loop.match = m.keyframe;
    step->loop.loop.descriptor_distance = m.distance;
    return Status::Ok();
  }
  auto points = store_->GetPoints(m.keyframe, &match_points_, &spill_buffer_);
  if (!points.ok()) {
    // The match's scan is gone (evicted): the candidate cannot be verified.
    step->loop.verdict = LoopVerdict::kIcpFailed;
    ++stats_.loop_candidates_rejected;
    return Status::Ok();
  }
  // ICP starts from the graph's estimate (loops already closed make it the better guess) ...
  const Eigen::Isometry3d T_match_query_graph = graph_.pose(m.keyframe).inverse() * graph_.pose(query);
  auto check = verifier_.Verify(query, m.keyframe, m.distance, Span<const PointXYZI>(voxels_),
                                Span<const PointXYZI>(match_points_), T_match_query_graph, params_.loop);
  if (!check.ok()) return check.status();
  step->loop = *check;
  if (check->verdict == LoopVerdict::kAccepted) {
    // ... but it must agree with the odometry chain alone, which no earlier loop can have bent, over the whole
    // path since the match, and with the graph over the path through the loops already closed.
    const LoopDetectorParams& lp = params_.loop;
    const double spacing_m = params_.keyframer.keyframe_spacing_m;
    const auto within_drift = [&](const Eigen::Isometry3d& T_match_query_prior, double path_m) {
      const Eigen::Isometry3d correction = T_match_query_prior.inverse() * check->loop.T_match_query;
      const double correction_deg = Eigen::AngleAxisd(correction.rotation()).angle() * 180.0 / kPi;
      return correction.translation().norm() <= lp.max_correction_m + lp.max_correction_per_travelled * path_m &&
             correction_deg <= lp.max_correction_deg + lp.max_correction_deg_per_travelled_m * path_m;
    };
    const Eigen::Isometry3d T_match_query_odom = T_odom_keyframes_[m.keyframe].inverse() * T_odom_keyframes_[query];
    const double chain_m = static_cast<double>(query - m.keyframe) * spacing_m;
    const double graph_path_m =
        static_cast<double>(graph_distance_.Steps(m.keyframe, query, graph_.num_nodes())) * spacing_m;
    if (!within_drift(T_match_query_odom, chain_m) || !within_drift(T_match_query_graph, graph_path_m)) {
      step->loop.verdict = LoopVerdict::kCorrectionTooLarge;
      ++stats_.loops_implausible;
    }
  }
  if (step->loop.verdict != LoopVerdict::kAccepted) {
    ++stats_.loop_candidates_rejected;
    return Status::Ok();
  }
  PoseGraphEdge loop;
  loop.from = m.keyframe;
  loop.to = query;
  loop.T_from_to = check->loop.T_match_query;
  loop.information = check->loop.information;
  loop.kind = EdgeKind::kLoop;
  if (Status s = graph_.AddEdge(loop); !s.ok()) return s;
  ++stats_.loops_accepted;
  if (check->loop.refined) ++stats_.loops_refined;
  ++stats_.pending_loops;
  if (optimised_once_ && query - last_optimisation_keyframe_ < params_.min_keyframes_between_optimisations) {
    return Status::Ok();
  }
  auto changed = OptimizePending();
  if (!changed.ok()) return changed.status();
  step->changed_keyframes = std::move(*changed);
  return Status::Ok();
}

Result<std::vector<std::uint32_t>> RobotMapper::OptimizePending() {
  if (stats_.pending_loops == 0) return std::vector<std::uint32_t>{};
  auto optimised = graph_.Optimize(params_.graph);
  if (!optimised.ok()) return optimised.status();
  ++stats_.optimisations;
  stats_.pending_loops = 0;
  // The loops are in the graph's estimate now: from here on they shorten the graph check's path.
  for (; linked_edges_ < graph_.num_edges(); ++linked_edges_) {
    const PoseGraphEdge& e = graph_.edge(linked_edges_);
    if (e.kind != EdgeKind::kLoop) continue;
    if (Status s = graph_distance_.AddLink(e.from, e.to); !s.ok()) return s;
  }
  optimised_once_ = true;
  last_optimisation_keyframe_ = static_cast<std::uint32_t>(graph_.num_nodes() - 1);
  return std::move(optimised->changed_nodes);
}

}  // namespace commerge
