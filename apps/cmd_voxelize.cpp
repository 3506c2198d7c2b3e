// SPDX-License-Identifier: BSD-3-Clause
// `commerge voxelize IN OUT`: voxel-grid downsampling of one point-cloud file (.bin, .pcd, .ply).
#include <cstdio>
#include <memory>
#include <string>

#include "apps/app_common.hpp"
#include "apps/commands.hpp"
#include "core/cloud/voxel_grid.hpp"
#include "platform/io/point_cloud_file.hpp"

namespace commerge::app {

Command AddVoxelizeCommand(CLI::App& root) {
  struct Opts {
    std::string input, output;
    double voxel_size_m = 1.0;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = root.add_subcommand(
      "voxelize", "Downsample a point cloud to one centroid per voxel (KITTI .bin, .pcd or .ply in and out)");
  cmd->add_option("input", o->input, "Input cloud (.bin KITTI, .pcd, .ply)")->required();
  cmd->add_option("output", o->output, "Output cloud (.bin, .pcd, .ply)")->required();
  cmd->add_option("--voxel-size-m", o->voxel_size_m, "Voxel edge length [m]")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  return {cmd, [o]() -> int {
            auto in = platform::ReadPointCloud(o->input);
            if (!in.ok()) {
              std::fprintf(stderr, "commerge voxelize: %s\n", in.status().message().c_str());
              return kExitFailure;
            }
            std::vector<PointXYZI> out;
            VoxelGridParams params;
            params.voxel_size_m = o->voxel_size_m;
            auto stats = VoxelDownsample(Span<const PointXYZI>(in->points), params, &out);
            if (!stats.ok()) {
              std::fprintf(stderr, "commerge voxelize: %s: %s\n", o->input.c_str(), stats.status().message().c_str());
              return kExitFailure;
            }
            if (Status st = platform::WritePointCloud(o->output, Span<const PointXYZI>(out)); !st.ok()) {
              std::fprintf(stderr, "commerge voxelize: %s\n", st.message().c_str());
              return kExitFailure;
            }
            std::printf("%s: %zu points (%zu non-finite dropped) -> %zu voxels of %.3g m -> %s\n", o->input.c_str(),
                        in->records_in_file, in->dropped_nonfinite, out.size(), o->voxel_size_m, o->output.c_str());
            return kExitOk;
          }};
}

}  // namespace commerge::app
