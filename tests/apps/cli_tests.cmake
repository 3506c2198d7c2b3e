# SPDX-License-Identifier: BSD-3-Clause
# End-to-end tests of the commerge executable (exit codes and messages), run through the emulator when
# cross-compiling. Included from tests/CMakeLists.txt.

cm_add_executable(cm_alloc_probe "${CMAKE_CURRENT_SOURCE_DIR}/support/alloc_probe.cpp")

set(CM_RUN_EXPECT "${CMAKE_CURRENT_SOURCE_DIR}/support/run_expect.cmake")
set(CM_EMU ${CMAKE_CROSSCOMPILING_EMULATOR})
set(CM_CLI_OUT "${CMAKE_CURRENT_BINARY_DIR}/cli")

# cm_cli_test(NAME <name> RC <code> [REGEX <re>] [FAKE_CGROUP <spec>] [LABELS ...] COMMAND <cmd...>)
function(cm_cli_test)
  cmake_parse_arguments(T "" "NAME;RC;REGEX;FAKE_CGROUP" "COMMAND;LABELS" ${ARGN})
  set(defs -DEXPECT_RC=${T_RC})
  if(DEFINED T_REGEX)
    list(APPEND defs "-DEXPECT_REGEX=${T_REGEX}")
  endif()
  if(DEFINED T_FAKE_CGROUP)
    list(APPEND defs "-DFAKE_CGROUP=${T_FAKE_CGROUP}")
  endif()
  list(JOIN T_COMMAND "|" joined)
  add_test(NAME "cli: ${T_NAME}" COMMAND "${CMAKE_COMMAND}" ${defs} "-DCMD=${joined}" -P "${CM_RUN_EXPECT}")
  if(T_LABELS)
    set_tests_properties("cli: ${T_NAME}" PROPERTIES LABELS "${T_LABELS}")
  endif()
endfunction()

set(CM_BIN ${CM_EMU} $<TARGET_FILE:commerge>)

cm_cli_test(NAME "version" RC 0 REGEX "commerge ${PROJECT_VERSION}" COMMAND ${CM_BIN} --version)
cm_cli_test(NAME "help lists the subcommands" RC 0 REGEX "demo.*budget.*voxelize.*sim" COMMAND ${CM_BIN} --help)
# The cascade's and the loop closure's thresholds and limits are flags with their units (issue: solver fidelity).
cm_cli_test(NAME "run --help lists the descriptors, the loop thresholds, the solvers' node limits and the cover with their units" RC 0
            REGEX "--descriptor[^=]*scan-context.*--tau-intra.*unit-vector L2 distance. Scan Context distance. paper: tau_intra.*--tau-window.*\\[keyframes\\].*--tau-icp[^=]*=0\\.3.*\\[m\\^2. paper: tau_ICP\\].*--stage-b-max-nodes[^=]*=20000.*\\[nodes. ours, not in the paper\\].*--stage-c-max-nodes[^=]*=2000000.*\\[nodes. ours, not in the paper\\].*--cover[^=]*=pairwise"
            COMMAND ${CM_BIN} run --help)
cm_cli_test(NAME "robot --help lists the loop thresholds with their units" RC 0
            REGEX "--descriptor[^=]*scan-context.*--tau-intra.*--tau-window.*--tau-icp[^=]*=0\\.3.*\\[m\\^2. paper: tau_ICP\\]"
            COMMAND ${CM_BIN} robot --help)
cm_cli_test(NAME "unknown subcommand is a usage error" RC 2 COMMAND ${CM_BIN} fly)
cm_cli_test(NAME "budget: jetson-nano server defaults fit" RC 0 REGEX "memory budget of server fits"
            COMMAND ${CM_BIN} budget --app server --board jetson-nano)
cm_cli_test(NAME "budget: over the board exits 3 naming module, need and limit" RC 3
            REGEX "over memory budget: module 'scan_store' needs 97.66 GiB.*exceeds the limit 2.47 GiB \\(jetson-nano board"
            COMMAND ${CM_BIN} budget --app robot --board jetson-nano --scan-store-mb 100000)
cm_cli_test(NAME "budget: over a cgroup v2 limit exits 3" RC 3
            REGEX "over memory budget: module 'scan_store'.*cgroup memory limit \\(256.0 MiB\\)"
            FAKE_CGROUP "${CM_CLI_OUT}/fake-cgroup|268435456"
            COMMAND ${CM_BIN} budget --app robot --board desktop --scan-store-mb 600
                    --proc-root "${CM_CLI_OUT}/fake-cgroup/proc" --cgroup-root "${CM_CLI_OUT}/fake-cgroup/cgroup")
cm_cli_test(NAME "budget: a negative size is a usage error" RC 2 REGEX "scan-store-mb"
            COMMAND ${CM_BIN} budget --scan-store-mb -5)
# The demo is the main job end to end (about 30 s natively): host only.
cm_cli_test(NAME "demo merges the two robots correctly and writes the report" RC 0 LABELS heavy
            REGEX "\\| A\\+B\\+C \\|.*T_world_map.*wrote .*merged_map.*commerge demo: correct merge, alignment RMSE 0\\.[0-9]+ m"
            COMMAND ${CM_BIN} demo --out "${CM_CLI_OUT}/demo")
set_tests_properties("cli: demo merges the two robots correctly and writes the report" PROPERTIES FIXTURES_SETUP demo_out)
cm_cli_test(NAME "voxelize reads the demo's merged map" RC 0 LABELS heavy
            REGEX "merged_map.pcd: [0-9]+ points \\(0 non-finite dropped\\)"
            COMMAND ${CM_BIN} voxelize "${CM_CLI_OUT}/demo/merged_map.pcd" "${CM_CLI_OUT}/demo/map_2m.ply" --voxel-size-m 2)
set_tests_properties("cli: voxelize reads the demo's merged map" PROPERTIES FIXTURES_REQUIRED demo_out)
foreach(file report/affinity_0_1.png report/trajectories_selected.png report/map_before.png report/map_after.png
        report/bytes_per_mode.png merged_map.ply transforms.txt trajectories/robot_1_world.tum trajectories/robot_1_gt.tum)
  add_test(NAME "cli: demo wrote ${file}" COMMAND "${CMAKE_COMMAND}" -E cat "${CM_CLI_OUT}/demo/${file}")
  set_tests_properties("cli: demo wrote ${file}" PROPERTIES FIXTURES_REQUIRED demo_out LABELS heavy)
endforeach()
# The run's own verdict against ground truth, send-all's bytes counted without the mode equal the mode's, and
# each mode's bytes by kind (stream + mode ledger) add up to the total it reports.
set(cm_kinds keyframes pose_updates policies scans status other)
set(cm_kind_sums "")
foreach(mode send-all A A+B A+C A+B+C)
  set(terms "")
  foreach(kind IN LISTS cm_kinds)
    list(APPEND terms "mode.${mode}.bytes.${kind}")
  endforeach()
  string(REPLACE ";" "," terms "${terms}")
  string(APPEND cm_kind_sums "|mode.${mode}.total_bytes==sum(${terms})")
endforeach()
set(cm_demo_metrics "cli: demo's metrics: robot 1 shares a place with robot 0 and is placed within 1 m (also where they met), send-all bytes as counted, bytes by kind sum to each mode's total")
add_test(NAME "${cm_demo_metrics}"
         COMMAND "${CMAKE_COMMAND}" "-DFILE=${CM_CLI_OUT}/demo/report/metrics.tsv"
                 "-DEXPECT=robot.1.reachable=1|robot.1.merged=1|robot.1.wrong=0|robot.1.error_m<1|robot.1.error_at_place_m<1|robot.1.place_partner=0|pair.0-1.stopped=merged|robot.1.loop_candidates_refused<1000000|stored_send_all_bytes==mode.send-all.total_bytes${cm_kind_sums}"
                 -P "${CMAKE_CURRENT_SOURCE_DIR}/apps/check_metrics.cmake")
set_tests_properties("${cm_demo_metrics}" PROPERTIES FIXTURES_REQUIRED demo_out LABELS heavy)
# Node limits of one node: stage B ends with a cover above its LP bound, printed per pair (status, incumbent,
# bound, gap, nodes, LPs); stage C, stopped after its root, solves its LP bound as the certificate of its gap
# (on this pair the LP closes it), and the run still merges from what it has.
cm_cli_test(NAME "run: with node limits of 1 the solvers' gaps are printed per pair" RC 0 LABELS heavy
            REGEX "solvers: stage B feasible with gap: [0-9]+ against bound [0-9]+ \\(gap [0-9.]+ %\\), node or time limit, 1 node, [0-9]+ LPs?; stage C [a-z ]+: [0-9.]+ [^;]*1 node, 1 LP"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/demo/data/robot_0" "${CM_CLI_OUT}/demo/data/robot_1" --no-report
                    --stage-b-max-nodes 1 --stage-c-max-nodes 1 --out "${CM_CLI_OUT}/run-node-limits")
set_tests_properties("cli: run: with node limits of 1 the solvers' gaps are printed per pair" PROPERTIES
                     FIXTURES_REQUIRED demo_out)
# Three robots with --cover joint: stage B is one cover over the three pairs (core SolveJointStageB), each pair
# prints the joint solve; all three robots merge. About 10 s natively: host only.
cm_cli_test(NAME "sim: three campus robots, 150 keyframes" RC 0 LABELS heavy
            REGEX "campus world, 3 robots, complete overlap, 150 keyframes each.*wrote "
            COMMAND ${CM_BIN} sim --world campus --robots 3 --overlap complete --keyframes 150 --seed 5
                    --azimuth-steps 900 --out "${CM_CLI_OUT}/sim-campus3" --force)
set_tests_properties("cli: sim: three campus robots, 150 keyframes" PROPERTIES FIXTURES_SETUP sim_campus3)
cm_cli_test(NAME "run: --cover joint solves one stage B over the three pairs and merges the three robots" RC 0
            LABELS heavy
            REGEX "solvers: stage B joint cover of 3 robots, optimal: [0-9]+ .*solvers: stage B joint cover of 3 robots, optimal: [0-9]+ .*solvers: stage B joint cover of 3 robots, optimal: [0-9]+ .*\\| A\\+B\\+C \\|.*\\| 3/3 \\|"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/sim-campus3/robot_0" "${CM_CLI_OUT}/sim-campus3/robot_1"
                    "${CM_CLI_OUT}/sim-campus3/robot_2" --cover joint --no-report --no-progress
                    --out "${CM_CLI_OUT}/run-joint")
set_tests_properties("cli: run: --cover joint solves one stage B over the three pairs and merges the three robots"
                     PROPERTIES FIXTURES_REQUIRED sim_campus3)
# The same three robots with Scan Context instead of the ring descriptor: 1226-byte records, stage A on the Scan
# Context distance; all three robots merge.
cm_cli_test(NAME "run: --descriptor scan-context merges the three campus robots" RC 0 LABELS heavy
            REGEX "descriptor: Scan Context 20 x 60.*neighbour rank 1 under tau_inter 0.5 .Scan Context distance.*\\| A\\+B\\+C \\|.*\\| 3/3 \\|"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/sim-campus3/robot_0" "${CM_CLI_OUT}/sim-campus3/robot_1"
                    "${CM_CLI_OUT}/sim-campus3/robot_2" --descriptor scan-context --no-report --no-progress
                    --out "${CM_CLI_OUT}/run-scan-context")
set_tests_properties("cli: run: --descriptor scan-context merges the three campus robots"
                     PROPERTIES FIXTURES_REQUIRED sim_campus3)
# Small scenes (issue: a courtyard walked twice with a handheld wide-field LiDAR): two 32-keyframe walks that meet
# where one ends and the other starts, OS0-128, the sensor held pitched. Seed 1 is the first seed; seed 10 is
# the tune seed on which levelling by the ground (core/slam/ground_up.hpp) turns A+B+C from refused into merged.
# With default flags send-all and A+B+C merge within 0.3 m / 2 deg of the truth. About 5 s each: host only.
foreach(seed 1 10)
  cm_cli_test(NAME "sim: a courtyard walked twice by hand, seed ${seed}" RC 0 LABELS heavy
              REGEX "courtyard world, 2 robots, partial overlap, 32 keyframes each, lidar os0-128.*wrote "
              COMMAND ${CM_BIN} sim --world courtyard --overlap partial --keyframes 32 --lidar os0-128 --seed ${seed}
                      --out "${CM_CLI_OUT}/sim-courtyard-${seed}" --force)
  set_tests_properties("cli: sim: a courtyard walked twice by hand, seed ${seed}" PROPERTIES
                       FIXTURES_SETUP sim_courtyard_${seed})
  cm_cli_test(NAME "run: the courtyard of seed ${seed} merges with default flags" RC 0 LABELS heavy
              REGEX "\\| A\\+B\\+C \\|.*\\| 1/1 \\|"
              COMMAND ${CM_BIN} run "${CM_CLI_OUT}/sim-courtyard-${seed}/robot_0" "${CM_CLI_OUT}/sim-courtyard-${seed}/robot_1"
                      --lidar os0-128 --no-progress --out "${CM_CLI_OUT}/run-courtyard-${seed}")
  set_tests_properties("cli: run: the courtyard of seed ${seed} merges with default flags" PROPERTIES
                       FIXTURES_REQUIRED sim_courtyard_${seed} FIXTURES_SETUP run_courtyard_${seed})
  set(cm_courtyard_metrics "cli: the courtyard of seed ${seed}: send-all and A+B+C place robot 1 within 0.3 m and 2 deg")
  add_test(NAME "${cm_courtyard_metrics}"
           COMMAND "${CMAKE_COMMAND}" "-DFILE=${CM_CLI_OUT}/run-courtyard-${seed}/report/metrics.tsv"
                   "-DEXPECT=mode.send-all.robots_merged=1/1|mode.send-all.worst_rmse_m<0.3|robot.1.merged=1|robot.1.wrong=0|robot.1.error_m<0.3|robot.1.error_deg<2"
                   -P "${CMAKE_CURRENT_SOURCE_DIR}/apps/check_metrics.cmake")
  set_tests_properties("${cm_courtyard_metrics}" PROPERTIES FIXTURES_REQUIRED run_courtyard_${seed} LABELS heavy)
endforeach()
cm_cli_test(NAME "voxelize names a missing file" RC 1 REGEX "does-not-exist.bin: no such file"
            COMMAND ${CM_BIN} voxelize "${CM_CLI_OUT}/does-not-exist.bin" "${CM_CLI_OUT}/x.pcd")


# commerge sim: tiny datasets (16 beams x 90 columns, a few keyframes) so that they stay fast under qemu.
cm_cli_test(NAME "sim: help lists the options" RC 0
            REGEX "--world.*--robots.*--overlap.*--keyframes.*--lidar.*--seed.*--drift.*--out.*--force"
            COMMAND ${CM_BIN} sim --help)
cm_cli_test(NAME "sim: writes a small KITTI dataset" RC 0
            REGEX "indoor world, 2 robots, complete overlap, 4 keyframes each.*robot 1: .*scans: 8 in .*wrote .*sim-a.*peak RSS"
            COMMAND ${CM_BIN} sim --world indoor --robots 2 --overlap complete --keyframes 4 --azimuth-steps 90 --seed 5
                    --out "${CM_CLI_OUT}/sim-a" --force)
set_tests_properties("cli: sim: writes a small KITTI dataset" PROPERTIES FIXTURES_SETUP sim_a)
cm_cli_test(NAME "sim: the same seed again, on two threads" RC 0 REGEX "scans: 8 in .*2 threads"
            COMMAND ${CM_BIN} sim --world indoor --robots 2 --overlap complete --keyframes 4 --azimuth-steps 90 --seed 5
                    --threads 2 --out "${CM_CLI_OUT}/sim-b" --force)
set_tests_properties("cli: sim: the same seed again, on two threads" PROPERTIES FIXTURES_SETUP sim_b)
foreach(file robot_1/velodyne/000003.bin robot_0/poses.txt robot_1/poses_gt.txt start_transforms.txt)
  add_test(NAME "cli: sim: same seed, identical ${file}"
           COMMAND "${CMAKE_COMMAND}" -E compare_files "${CM_CLI_OUT}/sim-a/${file}" "${CM_CLI_OUT}/sim-b/${file}")
  set_tests_properties("cli: sim: same seed, identical ${file}" PROPERTIES FIXTURES_REQUIRED "sim_a;sim_b")
endforeach()
cm_cli_test(NAME "sim: refuses a non-empty output directory without --force" RC 2
            REGEX "sim-a: already exists and is not empty \\(use --force"
            COMMAND ${CM_BIN} sim --keyframes 2 --out "${CM_CLI_OUT}/sim-a")
set_tests_properties("cli: sim: refuses a non-empty output directory without --force" PROPERTIES FIXTURES_REQUIRED sim_a)
cm_cli_test(NAME "sim: livox scans in a cave, 3 robots, partial overlap" RC 0
            REGEX "cave world, 3 robots, partial overlap.*lidar livox \\(400 rays/frame\\).*scans: 9 in"
            COMMAND ${CM_BIN} sim --world cave --robots 3 --overlap partial --keyframes 3 --lidar livox --livox-points 400
                    --out "${CM_CLI_OUT}/sim-cave" --force)
cm_cli_test(NAME "sim: poses only, 5 robots x 2000 keyframes" RC 0
            REGEX "5 robots, moderate overlap, 2000 keyframes each.*robot 4: 19[0-9][0-9] m driven"
            COMMAND ${CM_BIN} sim --world campus --robots 5 --keyframes 2000 --poses-only --out "${CM_CLI_OUT}/sim-poses" --force)
# Perceptual aliasing on the robot side: the generated indoor world repeats identical corridors, so the
# descriptor search proposes the wrong copy and ICP verifies it. Loops must be judged against the odometry
# chain and against the graph over the path through the loops already closed, never against the graph with
# the whole path's drift allowance: that way these two robots accepted 42 of 237 and 109 of 198 loops whose
# transform is more than 2 m or 10 deg off the ground truth, and their maps collapsed (odometry chain alone:
# 0 of 262 and 6 of 165; both checks: 0 of 262 and 0 of 159).
# The pair itself does not merge (stage A finds no cluster in the aliased affinity matrix): exit 1.
# About 20 s natively: host only.
cm_cli_test(NAME "sim: an aliased indoor world, two robots, 800 keyframes" RC 0 LABELS heavy
            REGEX "indoor world, 2 robots, complete overlap, 800 keyframes each.*scans: 1600 in"
            COMMAND ${CM_BIN} sim --world indoor --robots 2 --overlap complete --keyframes 800 --lidar vlp16 --seed 11
                    --threads 2 --direction same --wobble-deg 0 --detection-reflectivity 0.8
                    --out "${CM_CLI_OUT}/sim-indoor" --force)
set_tests_properties("cli: sim: an aliased indoor world, two robots, 800 keyframes"
                     PROPERTIES FIXTURES_SETUP sim_indoor)
# The paper's configuration (SOLiD, tau_window 100, per-cell stage A): the loops' median translation error against
# ground truth stays below 0.1 m: GICP refines each accepted loop (core/README.md "GICP refinement of intra-robot
# loops"). Measured: 0.067 and 0.082 m; point-to-point ICP alone
# gave 0.114 and 0.206 m (the corridors leave GICP little to fix along their axis; on the campus it is
# 0.11-0.20 m -> 0.004-0.006 m).
cm_cli_test(NAME "run: in the aliased indoor world the robots accept no false loop" RC 1 LABELS heavy
            REGEX "robot 0 [^=]* loops \\(0 false against ground truth, error median 0\\.0[0-9]+ m[^=]*\n *robot 1 [^=]* loops \\(0 false against ground truth, error median 0\\.0[0-9]+ m"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/sim-indoor/robot_0" "${CM_CLI_OUT}/sim-indoor/robot_1" --lidar vlp-16
                    --keyframe-spacing-m 0.9 --max-keyframes 900 --modes A+B+C --no-report --no-progress
                    --tau-window 100 --descriptor solid --neighbour-rank 0 --sequence-half-window 0 --tau-area 10000 --tau-area-fraction 0 --tau-inter 0.1
                    --verify-area-fraction 0 --out "${CM_CLI_OUT}/run-indoor")
# Stage A with the sequence-smoothed threshold (--sequence-half-window 8, core/README.md "Sequence-smoothed
# stage A"): the corridors' single-keyframe jumps above tau_inter no longer cut the revisit's diagonal, and the
# same pair merges within 1 m of the ground truth.
cm_cli_test(NAME "run: in the aliased indoor world the sequence-smoothed stage A merges the pair" RC 0 LABELS heavy
            REGEX "robot 1: T_world_map [^=]*; e_rmse 0\\.[0-9]+ m"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/sim-indoor/robot_0" "${CM_CLI_OUT}/sim-indoor/robot_1" --lidar vlp-16
                    --keyframe-spacing-m 0.9 --max-keyframes 900 --modes A+B+C --no-report --no-progress
                    --descriptor solid --neighbour-rank 0 --tau-area 10000 --tau-area-fraction 0 --tau-inter 0.1 --sequence-half-window 8
                    --verify-area-fraction 0
                    --out "${CM_CLI_OUT}/run-indoor-seq")
set_tests_properties("cli: run: in the aliased indoor world the robots accept no false loop"
                     "cli: run: in the aliased indoor world the sequence-smoothed stage A merges the pair"
                     PROPERTIES FIXTURES_REQUIRED sim_indoor)
cm_cli_test(NAME "run: --sequence-half-window above 32 is a usage error naming the flag" RC 2
            REGEX "--sequence-half-window: Value 33 not in range"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/none-a" "${CM_CLI_OUT}/none-b" --sequence-half-window 33
                    --out "${CM_CLI_OUT}/run-bad")
cm_cli_test(NAME "server: --sequence-half-window above 32 is a usage error naming the flag" RC 2
            REGEX "--sequence-half-window: Value 33 not in range"
            COMMAND ${CM_BIN} server --lcm-url memq:// --sequence-half-window 33 --check)
# The default simulator setting on the campus: robot 1 drives the laps the other way round with 0.5 deg of roll
# and pitch. The ground's range rings move with the tilt, so SOLiD on every point (the paper) finds no stage A
# cluster; leaving the ground out (--solid-min-z-m, with the threshold it needs) merges within 1 m.
cm_cli_test(NAME "sim: a campus world driven both ways with roll and pitch, two robots, 800 keyframes" RC 0 LABELS heavy
            REGEX "campus world, 2 robots, complete overlap, 800 keyframes each.*scans: 1600 in"
            COMMAND ${CM_BIN} sim --world campus --robots 2 --overlap complete --keyframes 800 --lidar vlp16 --seed 11
                    --threads 2 --detection-reflectivity 0.8 --out "${CM_CLI_OUT}/sim-campus" --force)
set_tests_properties("cli: sim: a campus world driven both ways with roll and pitch, two robots, 800 keyframes"
                     PROPERTIES FIXTURES_SETUP sim_campus)
cm_cli_test(NAME "run: campus with roll and pitch merges once SOLiD leaves the ground out" RC 0 LABELS heavy
            REGEX "robot 1: T_world_map [^=]*; e_rmse 0\\.[0-9]+ m"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/sim-campus/robot_0" "${CM_CLI_OUT}/sim-campus/robot_1" --lidar vlp-16
                    --descriptor solid --solid-min-z-m -0.5 --tau-inter 0.2 --neighbour-rank 0 --sequence-half-window 0
                    --tau-area 10000 --tau-area-fraction 0 --verify-area-fraction 0 --keyframe-spacing-m 0.9 --max-keyframes 900 --modes A+B+C
                    --no-report --no-progress --out "${CM_CLI_OUT}/run-campus-z")
cm_cli_test(NAME "run: campus with roll and pitch, SOLiD on every point: stage A finds no cluster" RC 1 LABELS heavy
            REGEX "pair 0-1: not merged: stage A: no cluster with span area >= tau_area"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/sim-campus/robot_0" "${CM_CLI_OUT}/sim-campus/robot_1" --lidar vlp-16
                    --keyframe-spacing-m 0.9 --max-keyframes 900 --modes A+B+C --no-report --no-progress
                    --descriptor solid --neighbour-rank 0 --sequence-half-window 0 --tau-area 10000 --tau-area-fraction 0 --tau-inter 0.1
                    --verify-area-fraction 0 --out "${CM_CLI_OUT}/run-campus")
# The same data with the default flags (ring descriptor on the levelled scan, stage A by neighbour rank): placed
# within 1 m and 3 deg of the truth.
cm_cli_test(NAME "run: campus with roll and pitch merges with the default flags" RC 0 LABELS heavy
            REGEX "against ground truth: 1 of 1 robots share a place with robot 0's team, 1 placed right, 0 wrong"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/sim-campus/robot_0" "${CM_CLI_OUT}/sim-campus/robot_1" --lidar vlp-16
                    --keyframe-spacing-m 0.9 --max-keyframes 900 --modes A+B+C --no-report --no-progress
                    --out "${CM_CLI_OUT}/run-campus-default")
set_tests_properties("cli: run: campus with roll and pitch merges once SOLiD leaves the ground out"
                     "cli: run: campus with roll and pitch, SOLiD on every point: stage A finds no cluster"
                     "cli: run: campus with roll and pitch merges with the default flags"
                     PROPERTIES FIXTURES_REQUIRED sim_campus)
cm_cli_test(NAME "run: --solid-min-z-m beyond the preset's range is a usage error naming the flag" RC 2
            REGEX "--solid-min-z-m: SOLiD parameters: min_z_m must be -infinity \\(off\\) or finite within"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/none-a" "${CM_CLI_OUT}/none-b" --lidar vlp-16 --descriptor solid --solid-min-z-m -90
                    --out "${CM_CLI_OUT}/run-bad")
cm_cli_test(NAME "robot: --solid-min-z-m beyond the preset's range is a usage error naming the flag" RC 2
            REGEX "--solid-min-z-m: SOLiD parameters: min_z_m"
            COMMAND ${CM_BIN} robot --id 0 --lcm-url memq:// --data "${CM_CLI_OUT}/none-a" --lidar vlp-16
                    --descriptor solid --solid-min-z-m 85 --check)
cm_cli_test(NAME "run: --solid-min-z-m with the ring descriptor is a usage error naming the flag" RC 2
            REGEX "--solid-min-z-m: applies to --descriptor solid only"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/none-a" "${CM_CLI_OUT}/none-b" --lidar vlp-16 --solid-min-z-m -0.5
                    --out "${CM_CLI_OUT}/run-bad")
cm_cli_test(NAME "sim: an unknown world is a usage error" RC 2 REGEX "--world: forest not in"
            COMMAND ${CM_BIN} sim --world forest --out "${CM_CLI_OUT}/sim-bad")
cm_cli_test(NAME "sim: six robots is a usage error" RC 2 REGEX "--robots: Value 6 not in range"
            COMMAND ${CM_BIN} sim --robots 6 --out "${CM_CLI_OUT}/sim-bad")
cm_cli_test(NAME "sim: one keyframe is a usage error" RC 2 REGEX "--keyframes"
            COMMAND ${CM_BIN} sim --keyframes 1 --out "${CM_CLI_OUT}/sim-bad")
cm_cli_test(NAME "sim: --livox-points needs the livox model" RC 2 REGEX "--livox-points applies to --lidar livox"
            COMMAND ${CM_BIN} sim --livox-points 100 --out "${CM_CLI_OUT}/sim-bad")

if(CM_WITH_MIMALLOC)
  add_test(NAME "oom: mimalloc heap cap raises std::bad_alloc" COMMAND ${CM_EMU} $<TARGET_FILE:cm_alloc_probe> --until-oom)
  set_tests_properties("oom: mimalloc heap cap raises std::bad_alloc" PROPERTIES
    ENVIRONMENT "MIMALLOC_RESERVE_OS_MEMORY=64MiB;MIMALLOC_LIMIT_OS_ALLOC=1"
    PASS_REGULAR_EXPRESSION "bad_alloc after [0-9]+ MiB")
endif()
if(NOT CMAKE_CROSSCOMPILING)  # peak RSS is measured natively (qemu inflates it)
  # The reference is the 64 MiB the probe touches between two runs, not an absolute figure: the probe's start-up
  # RSS depends on the build (ASan binaries start several times larger).
  add_test(NAME "profiling: peak-ram.sh reports the peak RSS of a command"
           COMMAND "${CMAKE_CURRENT_SOURCE_DIR}/apps/peak_ram_test.sh" "${PROJECT_SOURCE_DIR}/profiling/peak-ram.sh"
                   $<TARGET_FILE:cm_alloc_probe>)
endif()

# systemd stops the daemons with SIGTERM: the interrupted LCM wait is not an error, the exit lines are printed and
# the exit code is 0 (it was 1, "LCM handle failed"). memq:// keeps it off the network. Also under qemu.
cm_cli_test(NAME "server: SIGTERM ends it cleanly with exit 0 and its summary lines" RC 0
            REGEX "server: 0 merge rounds.*server auth: off.*peak RSS"
            COMMAND timeout --preserve-status -s TERM 3 ${CM_BIN} server --lcm-url memq:// --robots 2 --quiet
                    --out "${CM_CLI_OUT}/sigterm-server")
list(JOIN CM_EMU " " cm_emu_words)  # for a sh -c string: ';' would end the command
# tau_inter per sensor: with the paper's stage A (--neighbour-rank 0) the paper's table, 0.05 for the
# non-repetitive Avia and 0.10 for a spinning sensor; a given --tau-inter wins; with the neighbour rank a cap.
cm_cli_test(NAME "server --check: with --neighbour-rank 0, tau_inter follows --lidar unless --tau-inter is given, and names the Scan Context distance" RC 0
            REGEX "tau_inter 0\\.05 per cell, tau_area 400 cells [^,]*, stage B pairwise.*tau_inter 0\\.1 per cell, tau_area 400 cells [^,]*, stage B joint.*tau_inter 0\\.2 per cell.*neighbour rank 1 under tau_inter 0\\.5, tau_area 400 cells [^,]*, stage B.*under tau_inter 0\\.5 .Scan Context distance., tau_area 400 cells [^,]*, stage B pairwise"
            COMMAND sh -c "$1 server --lcm-url memq:// --check --lidar avia --neighbour-rank 0 && $1 server --lcm-url memq:// --check --lidar vlp-16 --neighbour-rank 0 --cover joint && $1 server --lcm-url memq:// --check --lidar avia --neighbour-rank 0 --tau-inter 0.2 && $1 server --lcm-url memq:// --check --lidar avia && $1 server --lcm-url memq:// --check --descriptor scan-context"
                    sh "${cm_emu_words} $<TARGET_FILE:commerge>")
# --profile paper is the paper's cascade in one flag: its stage A (tau_inter of the sensor's scan pattern per cell,
# tau_area 10 000 cells, no scaling) and SOLiD; a flag given on the command line wins over the profile.
cm_cli_test(NAME "server --check --profile paper prints the paper's stage A thresholds, and a given flag wins over the profile" RC 0
            REGEX "descriptor solid.*stage A tau_inter 0\\.1 per cell, tau_area 10000 cells, stage B pairwise.*stage A tau_inter 0\\.05 per cell, tau_area 10000 cells, stage B pairwise.*stage A tau_inter 0\\.1 per cell, tau_area 2500 cells, stage B joint.*stage A neighbour rank 1 under tau_inter 0\\.5, tau_area 400 cells"
            COMMAND sh -c "$1 server --lcm-url memq:// --check --profile paper && $1 server --lcm-url memq:// --check --profile paper --lidar avia && $1 server --lcm-url memq:// --check --profile paper --tau-area 2500 --cover joint && $1 server --lcm-url memq:// --check --profile commerge"
                    sh "${cm_emu_words} $<TARGET_FILE:commerge>")
cm_cli_test(NAME "server: an unknown --profile is a usage error naming the profiles" RC 2 REGEX "--profile.*commerge.*paper"
            COMMAND ${CM_BIN} server --lcm-url memq:// --check --profile fast)
cm_cli_test(NAME "keygen: writes a 0600 key the server accepts with --check, refuses to overwrite it" RC 2
            REGEX "configuration OK \\(--check\\).*messages signed with key id 4.*--auth-key.*mode 0644: it must be readable by its owner only"
            COMMAND sh -c "rm -rf \"$1\" && mkdir -p \"$1\" && $2 keygen --out \"$1/k\" --id 4 && ! $2 keygen --out \"$1/k\" 2>/dev/null && $2 server --lcm-url memq:// --robots 2 --auth-key \"$1/k\" --check && chmod 644 \"$1/k\" && $2 server --lcm-url memq:// --robots 2 --auth-key \"$1/k\" --check"
                    sh "${CM_CLI_OUT}/keygen" "${cm_emu_words} $<TARGET_FILE:commerge>")

# commerge run: argument errors (fast everywhere) and real runs (host only).
cm_cli_test(NAME "run: one dataset is a usage error" RC 2 REGEX "datasets"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/sim-a/robot_0")
cm_cli_test(NAME "run: a directory without scans names what is missing" RC 1 REGEX "no velodyne/ directory"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/nowhere" "${CM_CLI_OUT}/nowhere2" --out "${CM_CLI_OUT}/run-bad")
cm_cli_test(NAME "run: an unknown exchange mode is a usage error" RC 2 REGEX "unknown exchange mode 'B'"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/sim-a/robot_0" "${CM_CLI_OUT}/sim-a/robot_1" --modes A,B
                    --out "${CM_CLI_OUT}/run-bad")
set_tests_properties("cli: run: an unknown exchange mode is a usage error" PROPERTIES FIXTURES_REQUIRED sim_a)
# The pools of `run` follow its datasets: keyframes as the robots make them, the largest scan file's points, and
# smaller pools for a shorter slice (tests/apps/run_pools_test.sh computes both from the files and the output).
cm_cli_test(NAME "run: the pools follow the datasets, keyframes and scan points, and shrink with a shorter slice" RC 0
            REGEX "pools for [0-9]+ keyframes .robots made at most [0-9]+., [0-9]+ points a scan .largest file.*run pools follow the datasets"
            COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/run_pools_test.sh" "${CM_CLI_OUT}/run-pools"
                    "${cm_emu_words} $<TARGET_FILE:commerge>" "${CM_CLI_OUT}/sim-a/robot_0" "${CM_CLI_OUT}/sim-a/robot_1")
set_tests_properties("cli: run: the pools follow the datasets, keyframes and scan points, and shrink with a shorter slice"
                     PROPERTIES FIXTURES_REQUIRED sim_a)
cm_cli_test(NAME "run: --min-submap-scans above 1000 is a usage error" RC 2 REGEX "--min-submap-scans: Value 1001 not in range"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/nowhere" "${CM_CLI_OUT}/nowhere2" --min-submap-scans 1001
                    --out "${CM_CLI_OUT}/run-bad")
cm_cli_test(NAME "server: --min-submap-scans above 1000 is a usage error" RC 2 REGEX "--min-submap-scans: Value 1001 not in range"
            COMMAND ${CM_BIN} server --min-submap-scans 1001)
cm_cli_test(NAME "run: an empty time range is a usage error" RC 2 REGEX "range 5-5 is empty"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/sim-a/robot_0:5-5" "${CM_CLI_OUT}/sim-a/robot_1" --out "${CM_CLI_OUT}/run-bad")
cm_cli_test(NAME "run: tiny dataset, every mode, no pair merged is exit 1 with the reason" RC 1
            REGEX "\\| send-all \\|.*\\| A\\+B\\+C \\|.*not merged: stage A.*no robot pair could be merged"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/sim-a/robot_0" "${CM_CLI_OUT}/sim-a/robot_1" --lidar vlp-16
                    --keyframe-spacing-m 0.9 --no-report --scan-store-mb 16 --max-keyframes 100
                    --out "${CM_CLI_OUT}/run-tiny")
set_tests_properties("cli: run: tiny dataset, every mode, no pair merged is exit 1 with the reason" PROPERTIES
                     FIXTURES_REQUIRED sim_a)
# run --profile paper: SOLiD and the paper's stage A for the sensor (vlp-16 spins: tau_inter 0.1), in one flag.
cm_cli_test(NAME "run: --profile paper runs SOLiD and the paper's stage A" RC 1
            REGEX "descriptor: SOLiD vlp-16[^;]*; stage A tau_inter 0\\.1 per cell, tau_area 10000 cells, stage B pairwise"
            COMMAND ${CM_BIN} run "${CM_CLI_OUT}/sim-a/robot_0" "${CM_CLI_OUT}/sim-a/robot_1" --lidar vlp-16
                    --keyframe-spacing-m 0.9 --no-report --scan-store-mb 16 --max-keyframes 100 --modes A+B+C
                    --profile paper --out "${CM_CLI_OUT}/run-paper")
set_tests_properties("cli: run: --profile paper runs SOLiD and the paper's stage A" PROPERTIES FIXTURES_REQUIRED sim_a)
# The paper's protocol for one real sequence: two robots from two time ranges (KITTI 00 frames 0-9 and 5-15).
set(CM_KITTI00 "${CM_SHARED_DATA_DIR}/kitti/kitti00_frames0-15")
if(EXISTS "${CM_KITTI00}/velodyne")
  cm_cli_test(NAME "run: KITTI 00 split into two robots by time merges against ground truth" RC 0 LABELS heavy
              REGEX "robot 1: T_world_map .* e_rmse 0\\.[0-2][0-9]* m"
              COMMAND ${CM_BIN} run "${CM_KITTI00}:0-10" "${CM_KITTI00}:5-16" --gt-from-poses --tau-area 4 --descriptor solid --neighbour-rank 0
                      --sequence-half-window 0 --tau-inter 0.1 --no-report
                      --scan-store-mb 64 --max-keyframes 100 --out "${CM_CLI_OUT}/run-kitti00")
else()
  message(STATUS "CM-SKIP: ${CM_KITTI00} is absent: the KITTI 00 run test is not registered")
endif()

# The recall benchmark's quick slice with the default flags (profiling/bench_recall.sh --slice quick): the
# simulator's default setting on the campus with five robots (the case of issue "Merge recall": 0 of 10 pairs
# merged by the paper's stage A), the indoor world with three robots on a test seed (59, never tuned on) and the
# real hku2 halves. Every robot that shares a place is merged and none is wrong; the hku2 half lands within
# 0.3 m / 2 deg of the reference poses, judged where the robots met and by the start poses.
set(CM_HKU2 "${CM_SHARED_DATA_DIR}/real/hku2")
if(EXISTS "${CM_HKU2}/poses.txt" AND NOT CMAKE_CROSSCOMPILING)
  set(recall_quick "recall: quick slice (campus 5 robots with the simulator's defaults, indoor 3 robots on a test seed, hku2 halves) merges every robot that shares a place, none wrong")
  cm_cli_test(NAME "${recall_quick}" RC 0 LABELS heavy
              REGEX "summary: 3 scenarios; recall 7 of 7 robots that share a place \\(100\\.0 %\\); real splits: 1 of 1 robots merged; 0 wrong merges"
              COMMAND bash "${PROJECT_SOURCE_DIR}/profiling/bench_recall.sh" --commerge $<TARGET_FILE:commerge> --slice quick
                      --work "${CM_CLI_OUT}/recall-quick" --shared-data "${CM_SHARED_DATA_DIR}")
  set_tests_properties("cli: ${recall_quick}" PROPERTIES FIXTURES_SETUP recall_quick)
  add_test(NAME "cli: recall: the hku2 halves merge within 0.3 m and 2 deg of the reference poses"
           COMMAND "${CMAKE_COMMAND}" "-DFILE=${CM_CLI_OUT}/recall-quick/hku2-halves/run/report/metrics.tsv"
                   "-DEXPECT=robot.1.reachable=1|robot.1.merged=1|robot.1.wrong=0|robot.1.error_at_place_m<0.3|robot.1.error_at_place_deg<2|robot.1.error_m<0.3|robot.1.error_deg<2"
                   -P "${CMAKE_CURRENT_SOURCE_DIR}/apps/check_metrics.cmake")
  set_tests_properties("cli: recall: the hku2 halves merge within 0.3 m and 2 deg of the reference poses"
                       PROPERTIES FIXTURES_REQUIRED recall_quick LABELS heavy)
  # Scene-scaled voxels (off by default, core/README.md "Scene-scaled voxels"): the Livox scans keep 560 points
  # at 1 m (median), so the robots store them finer and the server registers the pair below 1 m, still right.
  cm_cli_test(NAME "run: with scene-scaled voxels the hku2 halves are stored and registered finer than 1 m, and merge"
              RC 0 LABELS heavy
              REGEX "scans stored finer than 1 m \\(--min-scan-points\\).*submaps [0-9]+ / [0-9]+ points at 0\\.[0-9]+ m; success.*1 placed right, 0 wrong"
              COMMAND ${CM_BIN} run "${CM_HKU2}:0-133" "${CM_HKU2}:133-266" --lidar avia --gt-from-poses
                      --odometry odom_poses.txt --min-scan-points 1000 --min-submap-points 4000 --modes A+B+C
                      --no-report --no-progress --out "${CM_CLI_OUT}/run-hku2-fine")
else()
  message(STATUS "CM-SKIP: ${CM_HKU2} is absent or this build cross-compiles: the recall quick-slice tests are not registered")
endif()

include("${CMAKE_CURRENT_SOURCE_DIR}/apps/house_tests.cmake")
include("${CMAKE_CURRENT_SOURCE_DIR}/apps/ros_tests.cmake")
include("${CMAKE_CURRENT_SOURCE_DIR}/apps/ros1_bridge_tests.cmake")
