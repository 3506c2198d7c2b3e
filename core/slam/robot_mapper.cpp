// SPDX-License-Identifier: BSD-3-Clause
#include "core/slam/robot_mapper.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/descriptor/sensor_presets.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"

namespace commerge {

Status ValidateRobotMapperParams(const RobotMapperParams& p) {
  if (Status s = ValidateKeyframerParams(p.keyframer); !s.ok()) return s;
  if (Status s = ValidateLoopDetectorParams(p.loop); !s.ok()) return s;
  if (Status s = ValidateAdaptiveVoxelParams(p.voxel); !s.ok()) return Status(s.code(), "robot mapper: " + s.message());
  if (!(p.odometry_sigma_translation_m > 0.0) || !(p.odometry_sigma_rotation_rad > 0.0) ||
      !(p.odometry_sigma_roll_pitch_rad > 0.0)) {
    return InvalidArgument("robot mapper: odometry_sigma_translation_m, odometry_sigma_rotation_rad and "
                           "odometry_sigma_roll_pitch_rad must be > 0");
  }
  const DescriptorInputParams& d = p.descriptor_input;
  if (!(d.local_map_window_m >= 0.0 && d.local_map_window_m <= 50.0)) {
    return InvalidArgument("robot mapper: descriptor local_map_window_m = " + std::to_string(d.local_map_window_m) +
                           " is outside [0, 50]");
  }
  if (!(d.voxel_m >= 0.05 && d.voxel_m <= 2.0)) {
    return InvalidArgument("robot mapper: descriptor voxel_m = " + std::to_string(d.voxel_m) + " is outside [0.05, 2]");
  }
  if (Status s = ValidateGroundUpParams(d.ground_up); !s.ok()) return InvalidArgument("robot mapper: " + s.message());
  return Status::Ok();
}

std::uint32_t DescriptorInputId(std::uint32_t descriptor_id, const DescriptorInputParams& input) noexcept {
  if (input.local_map_window_m <= 0.0 && !input.level) return descriptor_id;
  std::uint32_t h = detail::Fnv1aInt32(detail::kFnv1aOffset, static_cast<std::int32_t>(descriptor_id));
  h = detail::Fnv1aByte(h, static_cast<std::uint8_t>('i'));
  h = detail::Fnv1aDouble(h, input.local_map_window_m);
  h = detail::Fnv1aDouble(h, input.voxel_m);
  h = detail::Fnv1aByte(h, input.level ? 1 : 0);
  // Levelling by the ground changes what the descriptor sees only on leaning frames; mixed in when it is on.
  if (input.level && input.ground_up.min_frame_tilt_deg > 0.0) h = detail::Fnv1aDouble(h, input.ground_up.min_frame_tilt_deg);
  return h;
}

bool RobotMapper::levels_by_ground() const noexcept {
  const GroundUpParams& g = params_.descriptor_input.ground_up;
  return params_.descriptor_input.level && g.min_frame_tilt_deg > 0.0 && ground_up_.tilt_deg() > g.min_frame_tilt_deg;
}

std::uint32_t RobotMapper::descriptor_parameter_id() const noexcept {
  return DescriptorInputId(descriptor_->parameter_id(), params_.descriptor_input);
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
      // The descriptor input's joined cloud holds up to two raw scans (the scan and the local map's points).
      voxel_grid_((params.descriptor_input.local_map_window_m > 0.0 ? 2 : 1) * capacity.max_points_per_raw_scan),
      graph_distance_(capacity.max_keyframes),
      descriptor_scratch_(descriptor->dimension()) {
  voxels_.reserve(capacity.max_points_per_stored_scan);
  if (params.voxel.min_points > 0) voxel_scratch_.reserve(capacity.max_points_per_stored_scan);
  match_points_.reserve(capacity.max_points_per_stored_scan);
  T_odom_keyframes_.reserve(capacity.max_keyframes);
  encoded_.resize(EncodedScanBytes(capacity.max_points_per_stored_scan));
  // The descriptor input, reserved once (never grown by doubling): the levelled copy or joined cloud, the local
  // map's points (at most one raw scan) and the voxelised copy.
  const DescriptorInputParams& d = params.descriptor_input;
  const std::size_t raw = capacity.max_points_per_raw_scan;
  if (d.local_map_window_m > 0.0) {
    local_cloud_.reserve(2 * raw);
    local_points_.reserve(raw);
    local_scratch_.reserve(2 * raw);
  } else if (d.level) {
    local_cloud_.reserve(raw);
  }
  if (d.level && d.ground_up.min_frame_tilt_deg > 0.0) ground_z_.reserve(raw);
}

std::size_t RobotMapper::scan_workspace_bytes() const {
  return voxel_grid_.workspace_capacity_bytes() + (voxels_.capacity() + voxel_scratch_.capacity()) * sizeof(PointXYZI) +
         encoded_.capacity() +
         descriptor_scratch_.capacity() * sizeof(float) + local_keyframes_.capacity() * sizeof(LocalKeyframe) +
         (local_points_.capacity() + local_cloud_.capacity() + local_scratch_.capacity()) * sizeof(PointXYZI) +
         ground_z_.capacity() * sizeof(float);
}

namespace {

// Roll and pitch of the sensor against `up_odom` (the odometry frame's z, or the ground's up when the frame
// leans), as the rotation that removes them: R_level p has its z along up and keeps the sensor's heading.
Eigen::Matrix3d LevellingRotation(const Eigen::Isometry3d& T_odom_sensor, const Eigen::Matrix3d& R_up_odom) {
  const Eigen::Matrix3d R = R_up_odom * T_odom_sensor.linear();
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(YawRad(R), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return Rz.transpose() * R;
}

// The rotation that takes `up` to the frame's z (identity when `use` is false).
Eigen::Matrix3d UpRotation(const Eigen::Vector3d& up, bool use) {
  if (!use) return Eigen::Matrix3d::Identity();
  return Eigen::Quaterniond::FromTwoVectors(up, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

void AppendTransformed(Span<const PointXYZI> points, const Eigen::Matrix3f& R, const Eigen::Vector3f& t,
                       std::vector<PointXYZI>* out) {
  for (const PointXYZI& p : points) {
    const Eigen::Vector3f q = R * Eigen::Vector3f(p.x, p.y, p.z) + t;
    out->push_back({q.x(), q.y(), q.z(), p.intensity});
  }
}

}  // namespace

Result<Span<const PointXYZI>> RobotMapper::DescriptorInput(Span<const PointXYZI> raw_scan,
                                                           const Eigen::Isometry3d& T_odom_sensor) {
  const DescriptorInputParams& d = params_.descriptor_input;
  if (d.local_map_window_m <= 0.0 && !d.level) return raw_scan;
  Eigen::Matrix3f R_level = Eigen::Matrix3f::Identity();
  if (d.level) {
    Eigen::Matrix3d R = LevellingRotation(T_odom_sensor, UpRotation(ground_up_.up(), levels_by_ground()));
    if (d.ground_up.min_frame_tilt_deg > 0.0) {
      // This keyframe's ground, found in the cloud levelled so far, joins the estimate of up.
      local_cloud_.clear();
      AppendTransformed(raw_scan, R.cast<float>(), Eigen::Vector3f::Zero(), &local_cloud_);
      Eigen::Vector3d n_levelled;
      if (FitGroundNormal(Span<const PointXYZI>(local_cloud_), d.ground_up, &ground_z_, &n_levelled)) {
        ground_up_.Add(T_odom_sensor.linear() * R.transpose() * n_levelled);
        R = LevellingRotation(T_odom_sensor, UpRotation(ground_up_.up(), levels_by_ground()));
      }
    }
    R_level = R.cast<float>();
  }
  local_cloud_.clear();
  AppendTransformed(raw_scan, R_level, Eigen::Vector3f::Zero(), &local_cloud_);
  if (d.local_map_window_m <= 0.0) return Span<const PointXYZI>(local_cloud_);
  // Past keyframes within the window, in this keyframe's (levelled) sensor frame.
  const Eigen::Isometry3d T_sensor_odom = T_odom_sensor.inverse();
  for (const LocalKeyframe& k : local_keyframes_) {
    if (path_m_ - k.path_m > d.local_map_window_m) continue;
    const Eigen::Isometry3d T = T_sensor_odom * k.T_odom_sensor;
    AppendTransformed(Span<const PointXYZI>(local_points_.data() + k.begin, k.end - k.begin),
                      R_level * T.linear().cast<float>(), R_level * T.translation().cast<float>(), &local_cloud_);
  }
  VoxelGridParams v;
  v.voxel_size_m = d.voxel_m;
  auto vox = voxel_grid_.Downsample(Span<const PointXYZI>(local_cloud_), v, &local_scratch_);
  if (!vox.ok()) return vox.status();
  return Span<const PointXYZI>(local_scratch_);
}

Status RobotMapper::RememberForLocalMap(Span<const PointXYZI> raw_scan, const Eigen::Isometry3d& T_odom_sensor) {
  const DescriptorInputParams& d = params_.descriptor_input;
  if (d.local_map_window_m <= 0.0) return Status::Ok();
  // Keyframes that left the window, and the oldest ones while the points exceed one raw scan's capacity.
  std::size_t drop = 0;
  while (drop < local_keyframes_.size() && path_m_ - local_keyframes_[drop].path_m > d.local_map_window_m) ++drop;
  VoxelGridParams v;
  v.voxel_size_m = d.voxel_m;
  auto vox = voxel_grid_.Downsample(raw_scan, v, &local_scratch_);
  if (!vox.ok()) return vox.status();
  const std::size_t cap = capacity_.max_points_per_raw_scan;
  std::size_t kept = local_points_.size() - (drop < local_keyframes_.size() ? local_keyframes_[drop].begin : local_points_.size());
  while (drop < local_keyframes_.size() && kept + local_scratch_.size() > cap) {
    kept -= local_keyframes_[drop].end - local_keyframes_[drop].begin;
    ++drop;
  }
  if (drop > 0) {
    const std::size_t first = drop < local_keyframes_.size() ? local_keyframes_[drop].begin : local_points_.size();
    local_points_.erase(local_points_.begin(), local_points_.begin() + static_cast<std::ptrdiff_t>(first));
    local_keyframes_.erase(local_keyframes_.begin(), local_keyframes_.begin() + static_cast<std::ptrdiff_t>(drop));
    for (LocalKeyframe& k : local_keyframes_) {
      k.begin -= first;
      k.end -= first;
    }
  }
  const std::size_t n = std::min(local_scratch_.size(), cap);
  LocalKeyframe k;
  k.T_odom_sensor = T_odom_sensor;
  k.path_m = path_m_;
  k.begin = local_points_.size();
  local_points_.insert(local_points_.end(), local_scratch_.begin(), local_scratch_.begin() + static_cast<std::ptrdiff_t>(n));
  k.end = local_points_.size();
  local_keyframes_.push_back(k);
  return Status::Ok();
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

  // 2. Descriptor on the raw scan, or on its levelled local map (DescriptorInputParams).
  if (step.keyframe > 0) path_m_ += (T_odom_sensor.translation() - T_odom_last_keyframe_.translation()).norm();
  auto input = DescriptorInput(raw_scan, T_odom_sensor);
  if (!input.ok()) return input.status();
  auto info = descriptor_->Compute(*input, Span<float>(descriptor_scratch_));
  if (!info.ok()) return info.status();
  step.descriptor = *info;
  if (!step.descriptor.valid) ++stats_.invalid_descriptors;
  if (Status s = db_.Add(Span<const float>(descriptor_scratch_), step.descriptor.valid); !s.ok()) return s;

  if (Status s = RememberForLocalMap(raw_scan, T_odom_sensor); !s.ok()) return s;

  // 3. Voxelised scan into the store.
  AdaptiveVoxelParams voxel = params_.voxel;
  voxel.max_points = std::min(voxel.max_points, capacity_.max_points_per_stored_scan);
  auto vox = DownsampleAdaptive(&voxel_grid_, raw_scan, voxel, &voxels_, &voxel_scratch_);
  if (!vox.ok()) return vox.status();
  step.voxel_points = voxels_.size();
  step.voxel_size_m = vox->voxel_size_m;
  if (vox->finer_steps > 0) ++stats_.scans_stored_finer;
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
    const double wrp = 1.0 / (params_.odometry_sigma_roll_pitch_rad * params_.odometry_sigma_roll_pitch_rad);
    odom.information.diagonal() << wt, wt, wt, wrp, wrp, wr;
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
