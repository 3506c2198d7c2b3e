// SPDX-License-Identifier: BSD-3-Clause
// Round cost at scale (issue 34 item 4): the server's cascade for every robot pair of R robots x N keyframes,
// one thread. Goal: under 1 s on one core for the cascade of all ten pairs of 5 robots x 3 000 keyframes.
//
// Usage: bench_round [--robots R] [--keyframes N] [--more M] [--seed S] [--threads T] [--cover pairwise|joint]
//                    [--direction alternate|same] [--no-breakdown] [--cache FILE] [--disagree-odds X]
//   R robots (2..5, default 5), N keyframes each for the first round (default 3000), M more each for the second
//   round (default 300; 0 = one round), mission seed S (default 1), T threads for the setup only (default 1;
//   the timed rounds always run in the calling thread), stage B per pair (the server's default) or joint.
//
// Data: the simulator's urban world with complete overlap (PlanMission + BuildMissionWorld, as `commerge sim
// --world urban --overlap complete`: every robot drives the same shared tour, odd robots the other way round
// unless --direction same), the sim's default sensor (VLP-16, 16 x 1800 rays), default drift and wobble. Every
// keyframe's scan is ray-cast at its true pose (SimulateLidarScan, the sim's noise seeds). The descriptor is the
// product's default (apps MakeRobotDescriptor with --descriptor ring and a spinning --lidar): RingOccupancyDescriptor
// with RingOccupancyParams{} on the scan levelled by the keyframe's odometry pose (local map window 0); the
// levelling rotation is RobotMapper's (core/slam/robot_mapper.cpp LevellingRotation, copied here because it is
// file-local there). Descriptor id: DescriptorInputId(ring id, {level}). Poses sent are the odometry poses (the
// robots' intra-robot loop closure is not run); stored point counts are the 1 m voxel counts of the scans
// (capped at 8192, the store's limit). Every scan is cast, none reused.
//
// --cache FILE: when FILE holds the robots' data for the same robots, keyframes (N + M), seed and direction, the
// ray-casting is skipped and the data read from it; otherwise the data are simulated and written to FILE. The data
// are the same either way (floats and doubles stored bit for bit), so the timed rounds are too.
//
// Feeding: per robot, KeyframeBatch messages of up to 256 records (RobotAgentParams' default) encoded with
// EncodeRecordOfKind (kUnit40), robots interleaved batch by batch, into MergeServer::OnKeyframeBatch; keyframes
// without a valid descriptor go in a PoseUpdate with no_descriptor = 1, as RobotAgent sends them. The server is
// MergeServer(R, N + M, MergeServerParams{}) with record_kind kUnit40 (what `commerge server` uses for ring).
//
// Timed: MergeServer::RunCascades(), the round's cascade step (ServerLink calls it through MergeRound::Begin,
// `commerge run` directly). It recomputes every pair from the whole databases each round (pairs_ is cleared; nothing
// is cached between rounds), and besides the cascade (affinity + stage A with place consensus and place
// ambiguity, the descriptor agreement at the passed-on placement (--disagree-odds 0 leaves it out), B, C, policy)
// it runs the place check across pairs, and with --stage-ac stage C over all of L_seq
// for the A+C ablation plan (MergeServerParams::stage_ac_ablation: off in `commerge server` unless --mode A+C,
// so off here by default). Printed: the round's wall and CPU time, the per-stage times each pair's result records
// (ExchangeCascadeResult::stage_*_s) summed over the pairs and per pair, and the remainder (total minus the
// recorded stages: place ambiguity, A+C stage C, place check, input copies). The goal is judged on the round's
// CPU time (the machine may be shared).
//
// Breakdown (unless --no-breakdown): after each round, each pair's pieces are re-run outside the server on the
// server's own databases with the server's parameters, one at a time, to show where stage A's time goes: one
// pass of the affinity kernel over the whole matrix, one pass of the sequence-smoothed source, the neighbour
// rank's Prepare pass, RunSequentialMatching as the cascade calls it, RunCascadeStageA (adds the place consensus
// and the place ambiguity), and the A+C RunStageC. The matching runs on a kernel of the benchmark's own, whose cell
// count divided by N x M gives the number of passes stage A makes over the matrix.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <thread>
#include <vector>

#include <Eigen/Geometry>

#include "core/agent/merge_server.hpp"
#include "core/agent/messages.hpp"
#include "core/cloud/voxel_grid.hpp"
#include "core/descriptor/descriptor_codec.hpp"
#include "core/descriptor/ring_occupancy.hpp"
#include "core/exchange/affinity.hpp"
#include "core/exchange/edge_weighted_clique.hpp"
#include "core/exchange/exchange_cascade.hpp"
#include "core/exchange/neighbour_rank.hpp"
#include "core/exchange/sequence_smoothing.hpp"
#include "core/exchange/sequential_matching.hpp"
#include "core/geometry/se3.hpp"
#include "core/sim/lidar_models.hpp"
#include "core/sim/multi_robot_mission.hpp"
#include "core/sim/procedural_world.hpp"
#include "core/slam/robot_mapper.hpp"
#include "platform/memory/peak_rss.hpp"

using namespace commerge;

namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
double CpuSeconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

// What one robot sends: per keyframe its descriptor (valid or not), odometry pose and stored point count.
struct RobotData {
  std::vector<float> descriptors;  // keyframes x 40
  std::vector<std::uint8_t> valid;
  std::vector<Eigen::Isometry3d> T_map_sensor;
  std::vector<std::uint32_t> stored_points;
  std::vector<Eigen::Vector3d> gt_m;  // true positions (frame gt), for the share of true loops
};

// RobotMapper's levelling (core/slam/robot_mapper.cpp): removes the odometry pose's roll and pitch, keeps yaw.
Eigen::Matrix3f LevellingRotation(const Eigen::Isometry3d& T_odom_sensor) {
  const Eigen::Matrix3d R = T_odom_sensor.linear();
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(YawRad(R), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return (Rz.transpose() * R).cast<float>();
}

constexpr std::size_t kDim = kKeyframeDescriptorDim;
constexpr std::size_t kMaxStoredPoints = 8192;  // RobotMapperCapacity::max_points_per_stored_scan
constexpr std::size_t kRecordsPerBatch = 256;   // RobotAgentParams::max_records_per_batch

// Ray-casts and describes keyframes [0, count) of every robot with `threads` workers.
Status SimulateRobots(const MissionPlan& plan, const World& world, const LidarModel& lidar, std::size_t count,
                      int threads, std::vector<RobotData>* robots, std::size_t* scan_points) {
  const std::size_t num_robots = plan.robots.size();
  robots->assign(num_robots, RobotData{});
  for (std::size_t r = 0; r < num_robots; ++r) {
    RobotData& d = (*robots)[r];
    d.descriptors.assign(count * kDim, 0.0f);
    d.valid.assign(count, 0);
    d.T_map_sensor.resize(count);
    d.stored_points.assign(count, 0);
    d.gt_m.resize(count);
  }
  const std::size_t total = count * num_robots;
  std::atomic<std::size_t> next{0}, points{0};
  std::atomic<bool> failed{false};
  std::vector<Status> errors(static_cast<std::size_t>(threads));
  auto worker = [&](int id) {
    LidarScanWorkspace ws;
    std::vector<PointXYZI> scan, levelled, voxels;
    VoxelGrid grid;
    auto descriptor = RingOccupancyDescriptor::Create(RingOccupancyParams{});
    if (!descriptor.ok()) {
      errors[static_cast<std::size_t>(id)] = descriptor.status();
      failed = true;
      return;
    }
    std::size_t my_points = 0;
    while (!failed.load()) {
      const std::size_t job = next.fetch_add(1);
      if (job >= total) break;
      const std::size_t r = job / count, k = job % count;
      const RobotMission& robot = plan.robots[r];
      RobotData& d = (*robots)[r];
      Status st = SimulateLidarScan(world, lidar, robot.T_gt_sensor(k), ScanNoiseSeed(plan.params, static_cast<int>(r), k),
                                    k, &ws, &scan);
      if (st.ok()) {
        const Eigen::Matrix3f R = LevellingRotation(robot.odometry[k]);
        levelled.clear();
        for (const PointXYZI& p : scan) {
          const Eigen::Vector3f q = R * Eigen::Vector3f(p.x, p.y, p.z);
          levelled.push_back({q.x(), q.y(), q.z(), p.intensity});
        }
        auto info = descriptor->Compute(Span<const PointXYZI>(levelled), Span<float>(d.descriptors.data() + k * kDim, kDim));
        if (info.ok()) {
          d.valid[k] = info->valid ? 1 : 0;
          VoxelGridParams v;
          v.voxel_size_m = 1.0;
          auto vox = grid.Downsample(Span<const PointXYZI>(scan), v, &voxels);
          if (vox.ok()) {
            d.stored_points[k] = static_cast<std::uint32_t>(std::min(voxels.size(), kMaxStoredPoints));
          } else {
            st = vox.status();
          }
        } else {
          st = info.status();
        }
      }
      if (!st.ok()) {
        errors[static_cast<std::size_t>(id)] = st;
        failed = true;
        break;
      }
      d.T_map_sensor[k] = robot.odometry[k];
      d.gt_m[k] = robot.T_gt_sensor(k).translation();
      my_points += scan.size();
    }
    points += my_points;
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker, t);
  worker(0);
  for (std::thread& t : pool) t.join();
  for (const Status& e : errors) {
    if (!e.ok()) return e;
  }
  *scan_points = points.load();
  return Status::Ok();
}

// Sends keyframes [begin, end) of every robot: batches of up to 256 valid records (robots interleaved batch by
// batch), and one pose update per robot for keyframes without a valid descriptor.
Status Feed(const std::vector<RobotData>& robots, std::size_t begin, std::size_t end, std::uint32_t descriptor_id,
            std::vector<std::int32_t>* sequence, MergeServer* server, std::size_t* records, std::size_t* invalid) {
  const std::size_t record_bytes = KeyframeRecordBytesOf(KeyframeRecordKind::kUnit40);
  std::vector<std::size_t> cursor(robots.size(), begin);
  bool more = true;
  while (more) {
    more = false;
    for (std::size_t r = 0; r < robots.size(); ++r) {
      const RobotData& d = robots[r];
      KeyframeBatch batch;
      batch.utime_us = 1;
      batch.robot_id = static_cast<int>(r);
      batch.session = 1;
      batch.record_kind = KeyframeRecordKind::kUnit40;
      batch.descriptor_id = descriptor_id;
      PoseUpdate poses;
      poses.robot_id = static_cast<int>(r);
      poses.session = 1;
      std::size_t& k = cursor[r];
      while (k < end && batch.stored_points.size() < kRecordsPerBatch) {
        if (!d.valid[k]) {
          poses.keyframes.push_back(static_cast<std::uint32_t>(k));
          poses.T_map_sensor.push_back(d.T_map_sensor[k]);
          poses.no_descriptor.push_back(1);
          ++*invalid;
          ++k;
          continue;
        }
        const std::size_t offset = batch.records.size();
        batch.records.resize(offset + record_bytes);
        const KeyframePose pose{static_cast<std::uint32_t>(k), d.T_map_sensor[k]};
        if (Status st = EncodeRecordOfKind(KeyframeRecordKind::kUnit40, pose,
                                           Span<const float>(d.descriptors.data() + k * kDim, kDim),
                                           Span<std::uint8_t>(batch.records.data() + offset, record_bytes));
            !st.ok()) {
          return st;
        }
        batch.stored_points.push_back(d.stored_points[k]);
        ++*records;
        ++k;
      }
      if (!batch.stored_points.empty()) {
        batch.sequence = (*sequence)[r]++;
        if (Status st = server->OnKeyframeBatch(batch); !st.ok()) return st;
      }
      if (!poses.keyframes.empty()) {
        if (Status st = server->OnPoseUpdate(poses); !st.ok()) return st;
      }
      if (k < end) more = true;
    }
  }
  return Status::Ok();
}

// The --cache file: a header of the mission's identity, then per robot its arrays bit for bit.
struct CacheHeader {
  char magic[8] = {'b', 'r', 'c', 'a', 'c', 'h', 'e', '1'};
  std::uint64_t robots = 0, keyframes = 0, seed = 0, same_direction = 0, dim = kDim;
  std::uint64_t scan_points = 0;  // ray-cast points summed over the scans (printed)
};

bool SameHeader(const CacheHeader& a, const CacheHeader& b) {
  return std::memcmp(a.magic, b.magic, sizeof a.magic) == 0 && a.robots == b.robots && a.keyframes == b.keyframes &&
         a.seed == b.seed && a.same_direction == b.same_direction && a.dim == b.dim;
}

template <class T>
bool WriteArray(std::FILE* f, const std::vector<T>& v) {
  return std::fwrite(v.data(), sizeof(T), v.size(), f) == v.size();
}
template <class T>
bool ReadArray(std::FILE* f, std::vector<T>* v, std::size_t count) {
  v->resize(count);
  return std::fread(v->data(), sizeof(T), count, f) == count;
}

bool WriteCache(const char* path, const CacheHeader& h, const std::vector<RobotData>& robots) {
  std::FILE* f = std::fopen(path, "wb");
  if (!f) return false;
  bool ok = std::fwrite(&h, sizeof h, 1, f) == 1;
  for (const RobotData& d : robots) {
    std::vector<double> poses, gt;
    for (const Eigen::Isometry3d& T : d.T_map_sensor) poses.insert(poses.end(), T.data(), T.data() + 16);
    for (const Eigen::Vector3d& p : d.gt_m) gt.insert(gt.end(), p.data(), p.data() + 3);
    ok = ok && WriteArray(f, d.descriptors) && WriteArray(f, d.valid) && WriteArray(f, poses) &&
         WriteArray(f, d.stored_points) && WriteArray(f, gt);
  }
  return std::fclose(f) == 0 && ok;
}

// True when `path` holds data for `h` (read into *robots).
bool ReadCache(const char* path, const CacheHeader& h, std::vector<RobotData>* robots, std::size_t* scan_points) {
  std::FILE* f = std::fopen(path, "rb");
  if (!f) return false;
  CacheHeader got;
  bool ok = std::fread(&got, sizeof got, 1, f) == 1 && SameHeader(got, h);
  *scan_points = static_cast<std::size_t>(got.scan_points);
  const std::size_t n = static_cast<std::size_t>(h.keyframes);
  robots->assign(static_cast<std::size_t>(h.robots), RobotData{});
  for (RobotData& d : *robots) {
    if (!ok) break;
    std::vector<double> poses, gt;
    ok = ReadArray(f, &d.descriptors, n * kDim) && ReadArray(f, &d.valid, n) && ReadArray(f, &poses, n * 16) &&
         ReadArray(f, &d.stored_points, n) && ReadArray(f, &gt, n * 3);
    if (!ok) break;
    d.T_map_sensor.resize(n);
    d.gt_m.resize(n);
    for (std::size_t k = 0; k < n; ++k) {
      std::copy(poses.begin() + static_cast<std::ptrdiff_t>(16 * k), poses.begin() + static_cast<std::ptrdiff_t>(16 * k + 16),
                d.T_map_sensor[k].data());
      d.gt_m[k] = Eigen::Vector3d(gt[3 * k], gt[3 * k + 1], gt[3 * k + 2]);
    }
  }
  std::fclose(f);
  return ok;
}

std::vector<Eigen::Vector3d> Positions(const RobotKeyframeDb& db) {
  std::vector<Eigen::Vector3d> p(db.size());
  for (std::size_t k = 0; k < db.size(); ++k) p[k] = db.T_map_sensor[k].translation();
  return p;
}

CascadeRobotInput Input(const RobotKeyframeDb& db, const std::vector<Eigen::Vector3d>& positions) {
  return CascadeRobotInput{{Span<const float>(db.descriptors), db.dim, Span<const std::uint8_t>(db.valid)},
                           Span<const Eigen::Vector3d>(positions), Span<const std::uint32_t>(db.stored_points)};
}

// Loops whose two keyframes lie within 5 m of each other in truth.
std::size_t TrueLoops(const std::vector<SequentialLoopCell>& loops, const RobotData& a, const RobotData& b) {
  std::size_t n = 0;
  for (const SequentialLoopCell& l : loops) n += (a.gt_m[l.alpha_index] - b.gt_m[l.beta_index]).norm() < 5.0;
  return n;
}

struct RoundFigures {
  double wall_s = 0.0, cpu_s = 0.0;
};

// Prints the round's per-pair and summed figures.
void PrintRound(const MergeServer& server, const std::vector<RobotData>& robots, const RoundFigures& f) {
  const int n = server.max_robots();
  std::printf("  %-5s %8s %8s %8s %8s %8s | %7s %6s %5s %6s %6s %6s %7s  %s\n", "pair", "A [s]", "B [s]", "C [s]",
              "pol [s]", "sum [s]", "|L_seq|", "true", "cover", "|L_V|", "|L_K|", "A+C|LK|", "cells<t", "outcome");
  double sa = 0, sb = 0, sc = 0, sp = 0;
  std::size_t pairs = 0;
  for (int a = 0; a < n; ++a) {
    for (int b = a + 1; b < n; ++b) {
      const ExchangeCascadeResult* c = server.cascade(a, b);
      if (!c) {
        std::printf("  %d-%d   not run\n", a, b);
        continue;
      }
      ++pairs;
      const StageCResult* ac = server.stage_ac(a, b);
      sa += c->stage_a_s;
      sb += c->stage_b_s;
      sc += c->stage_c_s;
      sp += c->policy_s;
      const std::size_t cover = c->stage_b.selected_left.size() + c->stage_b.selected_right.size();
      std::string outcome = CascadeOutcomeName(c->outcome);
      if (!c->no_candidate_reason.empty()) outcome += ": " + c->no_candidate_reason.substr(0, 90);
      if (c->verification) outcome += " (verification)";
      if (c->ambiguous) outcome += " (ambiguous)";
      std::printf("  %d-%d   %8.4f %8.4f %8.4f %8.4f %8.4f | %7zu %5.1f%% %5zu %6zu %6zu %6zu %7llu  %s\n", a, b,
                  c->stage_a_s, c->stage_b_s, c->stage_c_s, c->policy_s,
                  c->stage_a_s + c->stage_b_s + c->stage_c_s + c->policy_s, c->stage_a.cells.size(),
                  c->stage_a.cells.empty() ? 0.0
                                           : 100.0 * static_cast<double>(TrueLoops(c->stage_a.cells, robots[static_cast<std::size_t>(a)],
                                                                                   robots[static_cast<std::size_t>(b)])) /
                                                 static_cast<double>(c->stage_a.cells.size()),
                  cover, c->stage_c.candidate_loops.size(), c->stage_c.selected_loops.size(),
                  ac ? ac->selected_loops.size() : 0, static_cast<unsigned long long>(c->stage_a.num_cells_below_threshold),
                  outcome.c_str());
    }
  }
  const double stages = sa + sb + sc + sp;
  std::printf("  summed over %zu pairs: A %.3f s, B %.3f s, C %.3f s, policy %.3f s = %.3f s; rest of RunCascades "
              "%.3f s (place ambiguity, A+C stage C, place check)\n",
              pairs, sa, sb, sc, sp, stages, f.wall_s - stages);
  std::printf("  RunCascades: %.3f s wall, %.3f s CPU (one thread)\n", f.wall_s, f.cpu_s);
}

// Re-runs each pair's pieces outside the server (see the file comment) and prints their times.
Status PrintBreakdown(const MergeServer& server) {
  const ExchangeCascadeParams& p = server.params().cascade;
  const SequentialMatchParams& sa = p.stage_a;
  const std::size_t halo = SequentialMatchTileHalo(sa);
  const int n = server.max_robots();
  std::vector<std::vector<Eigen::Vector3d>> positions;
  for (int r = 0; r < n; ++r) positions.push_back(Positions(server.robot(r)));
  std::printf("  breakdown, each piece re-run alone on the server's data [s]: affin. = one kernel pass over the N x M "
              "matrix; smoothed = one pass of the sequence-smoothed source; rank prep = NeighbourRankTileSource::Prepare; "
              "matching = RunSequentialMatching; cascadeA = RunCascadeStageA (matching, verification retry, place "
              "consensus, place ambiguity); (ambig.) = cascadeA minus its stage_a_s; A+C C = RunStageC over all of "
              "L_seq; passes = kernel cells the matching computed / (N M)\n");
  std::printf("  %-5s %9s %9s %9s %9s %9s %9s %9s | %8s %9s %7s\n", "pair", "affin.", "smoothed", "rank prep",
              "matching", "cascadeA", "(ambig.)", "A+C C", "clusters", "collected", "passes");
  double t_aff = 0, t_smooth = 0, t_rank = 0, t_match = 0, t_casc = 0, t_amb = 0, t_ac = 0;
  for (int a = 0; a < n; ++a) {
    for (int b = a + 1; b < n; ++b) {
      if (!server.cascade(a, b)) continue;
      const RobotKeyframeDb& A = server.robot(a);
      const RobotKeyframeDb& B = server.robot(b);
      const CascadeRobotInput ia = Input(A, positions[static_cast<std::size_t>(a)]);
      const CascadeRobotInput ib = Input(B, positions[static_cast<std::size_t>(b)]);
      auto kernel = AffinityTileKernel::Create(ia.descriptors, ib.descriptors, sa.tile_rows + halo, sa.tile_cols + halo);
      if (!kernel.ok()) return kernel.status();
      auto t0 = Clock::now();
      Status s = ForEachAffinityTile(*kernel, sa.tile_rows, sa.tile_cols, [](const AffinityTile&) { return Status::Ok(); });
      if (!s.ok()) return s;
      const double aff = SecondsSince(t0);
      double smooth = 0.0, rank = 0.0;
      if (sa.sequence_half_window > 0) {
        auto smoothed = SequenceSmoothedTileSource::Create(&*kernel, sa.sequence_half_window, sa.tile_rows, sa.tile_cols);
        if (!smoothed.ok()) return smoothed.status();
        t0 = Clock::now();
        s = ForEachAffinityTile(*smoothed, sa.tile_rows, sa.tile_cols, [](const AffinityTile&) { return Status::Ok(); });
        if (!s.ok()) return s;
        smooth = SecondsSince(t0);
        if (sa.neighbour_rank > 0) {
          auto ranked = NeighbourRankTileSource::Create(&*smoothed, sa.neighbour_rank, sa.tile_rows, sa.tile_cols);
          if (!ranked.ok()) return ranked.status();
          t0 = Clock::now();
          if (Status st = ranked->Prepare(); !st.ok()) return st;
          rank = SecondsSince(t0);
        }
      }
      // The matching as the cascade's StageA runs it (RunSequentialMatching over a kernel of this capacity), on a
      // kernel of our own so that its cell count says how many passes over the matrix stage A makes.
      SequentialMatchParams mp = sa;
      mp.all_clusters_max_cells = p.consensus_max_cells;
      auto match_kernel =
          AffinityTileKernel::Create(ia.descriptors, ib.descriptors, sa.tile_rows + halo, sa.tile_cols + halo);
      if (!match_kernel.ok()) return match_kernel.status();
      t0 = Clock::now();
      auto match = RunSequentialMatching(*match_kernel, mp);
      if (!match.ok()) return match.status();
      const double matching = SecondsSince(t0);
      const double passes = static_cast<double>(match_kernel->cells_computed()) /
                            (static_cast<double>(A.size()) * static_cast<double>(B.size()));
      t0 = Clock::now();
      auto cascade_a = RunCascadeStageA(ia, ib, p);
      if (!cascade_a.ok()) return cascade_a.status();
      const double casc = SecondsSince(t0);
      const double amb = casc - cascade_a->stage_a_s;
      double ac_s = 0.0;
      const auto& l_seq = cascade_a->stage_a.cells;
      if (!l_seq.empty()) {
        std::vector<int> all_a, all_b;
        for (const SequentialLoopCell& l : l_seq) {
          all_a.push_back(static_cast<int>(l.alpha_index));
          all_b.push_back(static_cast<int>(l.beta_index));
        }
        std::sort(all_a.begin(), all_a.end());
        all_a.erase(std::unique(all_a.begin(), all_a.end()), all_a.end());
        std::sort(all_b.begin(), all_b.end());
        all_b.erase(std::unique(all_b.begin(), all_b.end()), all_b.end());
        StageCParams c = p.stage_c;
        c.loop_set = StageCLoopSet::kBothEndpointsSelected;
        t0 = Clock::now();
        auto ac = RunStageC(Span<const SequentialLoopCell>(l_seq), Span<const int>(all_a), Span<const int>(all_b),
                            ia.positions_m, ib.positions_m, c);
        if (!ac.ok()) return ac.status();
        ac_s = SecondsSince(t0);
      }
      t_aff += aff;
      t_smooth += smooth;
      t_rank += rank;
      t_match += matching;
      t_casc += casc;
      t_amb += amb;
      t_ac += ac_s;
      std::printf("  %d-%d   %9.4f %9.4f %9.4f %9.4f %9.4f %9.4f %9.4f | %8zu %9s %7.2f\n", a, b, aff, smooth, rank,
                  matching, casc, amb, ac_s, match->num_clusters,
                  match->clusters_skipped ? "skipped" : (match->clusters.clusters.empty() ? "none" : "yes"), passes);
    }
  }
  std::printf("  summed: affinity pass %.3f s, smoothed pass %.3f s, rank prepare %.3f s; matching %.3f s, cascade "
              "stage A %.3f s (of which place ambiguity %.3f s), A+C stage C %.3f s\n",
              t_aff, t_smooth, t_rank, t_match, t_casc, t_amb, t_ac);
  return Status::Ok();
}

int Usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s [--robots 2..5] [--keyframes N] [--more M] [--seed S] [--threads T] "
               "[--cover pairwise|joint] [--direction alternate|same] [--stage-ac] [--no-breakdown] [--cache FILE] "
               "[--disagree-odds X]\n",
               argv0);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  int robots = 5, keyframes = 3000, more = 300, threads = 1;
  unsigned long long seed = 1;
  bool breakdown = true, same_direction = false, stage_ac = false;
  const char* cache = nullptr;
  StageBCover cover = StageBCover::kPairwise;
  double disagree_odds = PairDecisionParams{}.disagree_odds;
  for (int i = 1; i < argc; ++i) {
    const bool has_value = i + 1 < argc;
    if (std::strcmp(argv[i], "--robots") == 0 && has_value) {
      robots = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--keyframes") == 0 && has_value) {
      keyframes = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--more") == 0 && has_value) {
      more = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--seed") == 0 && has_value) {
      seed = std::strtoull(argv[++i], nullptr, 10);
    } else if (std::strcmp(argv[i], "--threads") == 0 && has_value) {
      threads = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--cover") == 0 && has_value) {
      auto c = StageBCoverFromName(argv[++i]);
      if (!c.ok()) {
        std::fprintf(stderr, "bench_round: %s\n", c.status().message().c_str());
        return 2;
      }
      cover = *c;
    } else if (std::strcmp(argv[i], "--direction") == 0 && has_value) {
      const std::string d = argv[++i];
      if (d != "alternate" && d != "same") return Usage(argv[0]);
      same_direction = d == "same";
    } else if (std::strcmp(argv[i], "--cache") == 0 && has_value) {
      cache = argv[++i];
    } else if (std::strcmp(argv[i], "--disagree-odds") == 0 && has_value) {
      disagree_odds = std::strtod(argv[++i], nullptr);
    } else if (std::strcmp(argv[i], "--stage-ac") == 0) {
      stage_ac = true;
    } else if (std::strcmp(argv[i], "--no-breakdown") == 0) {
      breakdown = false;
    } else {
      return Usage(argv[0]);
    }
  }
  if (robots < 2 || robots > 5 || keyframes < 2 || more < 0 || threads < 1 || threads > 64) {
    std::fprintf(stderr, "bench_round: need 2 <= robots <= 5, keyframes >= 2, more >= 0, 1 <= threads <= 64\n");
    return 2;
  }
  const std::size_t first = static_cast<std::size_t>(keyframes), total = first + static_cast<std::size_t>(more);

  // Setup: mission, world, scans, descriptors.
  const auto t_setup = Clock::now();
  MissionParams mission;
  mission.world = WorldKind::kUrban;
  mission.overlap = OverlapMode::kComplete;
  mission.robots = robots;
  mission.keyframes_per_robot = static_cast<int>(total);
  mission.seed = seed;
  mission.same_direction = same_direction;
  auto plan = PlanMission(mission);
  if (!plan.ok()) {
    std::fprintf(stderr, "bench_round: mission: %s\n", plan.status().ToString().c_str());
    return 1;
  }
  auto world = BuildMissionWorld(*plan);
  if (!world.ok()) {
    std::fprintf(stderr, "bench_round: world: %s\n", world.status().ToString().c_str());
    return 1;
  }
  const LidarModel lidar = MakeLidarModel(LidarKind::kVlp16);
  const double plan_s = SecondsSince(t_setup);
  std::vector<RobotData> data;
  std::size_t scan_points = 0;
  const auto t_cast = Clock::now();
  CacheHeader header;
  header.robots = static_cast<std::uint64_t>(robots);
  header.keyframes = total;
  header.seed = seed;
  header.same_direction = same_direction ? 1 : 0;
  const bool cached = cache != nullptr && ReadCache(cache, header, &data, &scan_points);
  if (!cached) {
    if (Status st = SimulateRobots(*plan, *world, lidar, total, threads, &data, &scan_points); !st.ok()) {
      std::fprintf(stderr, "bench_round: simulation: %s\n", st.ToString().c_str());
      return 1;
    }
    header.scan_points = scan_points;
    if (cache != nullptr && !WriteCache(cache, header, data)) {
      std::fprintf(stderr, "bench_round: cannot write the cache %s\n", cache);
      return 1;
    }
  }
  const double cast_s = SecondsSince(t_cast);
  DescriptorInputParams input;
  input.level = true;  // RingDescriptorInput for a spinning sensor: levelled, no local map
  const std::uint32_t descriptor_id = DescriptorInputId(RingOccupancyDescriptor().parameter_id(), input);
  std::size_t valid = 0;
  for (const RobotData& d : data) valid += static_cast<std::size_t>(std::count(d.valid.begin(), d.valid.end(), 1));
  const OverlapReport overlap = MeasureOverlap(*plan);
  double overlap_min = 1.0;
  for (double v : overlap.any) overlap_min = std::min(overlap_min, v);
  std::printf("mission: urban, complete overlap (%s direction), %d robots x %zu keyframes (%zu + %d), seed %llu; "
              "every robot's keyframes within 6 m of another robot's: >= %.0f %%\n",
              same_direction ? "same" : "alternating", robots, total, first, more, seed, 100.0 * overlap_min);
  std::printf("scans: %s, %d rays each, %zu scans ray-cast (%.0f points/scan), ring descriptor (8 rings x 5 bands) on "
              "the levelled scan, %zu valid (%.2f %%)\n",
              LidarKindName(lidar.kind), lidar.rays_per_frame(), total * data.size(),
              static_cast<double>(scan_points) / static_cast<double>(total * data.size()), valid,
              100.0 * static_cast<double>(valid) / static_cast<double>(total * data.size()));
  if (cached) {
    std::printf("setup: plan + world %.1f s, scans and descriptors read from %s\n", plan_s, cache);
  } else {
    std::printf("setup: plan + world %.1f s, ray-cast + descriptors %.1f s with %d thread%s (%.0f scans/s)\n", plan_s,
                cast_s, threads, threads > 1 ? "s" : "", static_cast<double>(total * data.size()) / cast_s);
  }

  MergeServerParams params;
  params.record_kind = KeyframeRecordKind::kUnit40;
  params.cover = cover;
  params.stage_ac_ablation = stage_ac;  // off: as `commerge server --mode A+B+C` (the default) runs it
  params.decision.disagree_odds = disagree_odds;  // 0: no descriptor agreement at the placement (its cost apart)
  auto made = MergeServer::Create(robots, total, params);
  if (!made.ok()) {
    std::fprintf(stderr, "bench_round: %s\n", made.status().message().c_str());
    return 2;
  }
  MergeServer& server = **made;
  std::printf("server: MergeServerParams{} (stage A neighbour rank %zu, sequence half window %zu, tau_area %llu "
              "scaled by %.2f, tau_inter %.2f; place consensus up to %zu cells; stage B %s; chain check %.0f; disagree odds "
              "%g)\n",
              server.params().cascade.stage_a.neighbour_rank, server.params().cascade.stage_a.sequence_half_window,
              static_cast<unsigned long long>(server.params().cascade.stage_a.tau_area),
              server.params().cascade.stage_a.tau_area_fraction, server.params().cascade.stage_a.tau_inter,
              server.params().cascade.consensus_max_cells, StageBCoverName(cover), server.params().decision.chain_check_support,
              server.params().decision.disagree_odds);

  std::vector<std::int32_t> sequence(static_cast<std::size_t>(robots), 0);
  const int num_pairs = robots * (robots - 1) / 2;
  std::vector<RoundFigures> rounds;
  const std::size_t ends[2] = {first, total};
  for (int round = 0; round < (more > 0 ? 2 : 1); ++round) {
    const std::size_t begin = round == 0 ? 0 : first, end = ends[round];
    std::size_t records = 0, invalid = 0;
    const auto t_feed = Clock::now();
    if (Status st = Feed(data, begin, end, descriptor_id, &sequence, &server, &records, &invalid); !st.ok()) {
      std::fprintf(stderr, "bench_round: feeding: %s\n", st.ToString().c_str());
      return 1;
    }
    const double feed_s = SecondsSince(t_feed);
    std::printf("\n== round %d: %zu keyframes per robot (fed keyframes %zu..%zu: %zu records, %zu pose-only, %.2f s) ==\n",
                round + 1, end, begin, end - 1, records, invalid, feed_s);
    RoundFigures f;
    const double c0 = CpuSeconds();
    const auto t0 = Clock::now();
    const Status st = server.RunCascades();
    f.wall_s = SecondsSince(t0);
    f.cpu_s = CpuSeconds() - c0;
    if (!st.ok()) {
      std::fprintf(stderr, "bench_round: RunCascades: %s\n", st.ToString().c_str());
      return 1;
    }
    PrintRound(server, data, f);
    if (breakdown) {
      if (Status b = PrintBreakdown(server); !b.ok()) {
        std::fprintf(stderr, "bench_round: breakdown: %s\n", b.ToString().c_str());
        return 1;
      }
    }
    rounds.push_back(f);
  }

  std::printf("\npeak RSS %s\n", FormatBytes(platform::ReadRss().peak_bytes).c_str());
  std::printf("setup (plan, world, ray-cast, descriptors) %.1f s\n", plan_s + cast_s);
  for (std::size_t i = 0; i < rounds.size(); ++i) {
    std::printf("goal: < 1 s for the cascade of all %d pair%s on one core: %s (round %zu, %zu keyframes per robot: "
                "RunCascades %.3f s CPU, %.3f s wall)\n",
                num_pairs, num_pairs > 1 ? "s" : "", rounds[i].cpu_s < 1.0 ? "met" : "not met", i + 1, ends[i], rounds[i].cpu_s, rounds[i].wall_s);
  }
  return 0;
}
