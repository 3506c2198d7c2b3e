// SPDX-License-Identifier: BSD-3-Clause
// The LCM decoders under fuzzing: one row per decoder, X(name, Message, Decode, Encode, malloc_limit_mb) with the
// plain message struct (namespace commerge), its codec functions (namespace commerge::platform) and the target's
// libFuzzer -malloc_limit_mb: one allocation above it fails the run. Pick it above the largest block that
// decoding the largest legal message needs, plus the two copies of the input libFuzzer holds (the CTest test runs
// that message first, when seed_corpus.cpp makes one). For the rows below the largest legal message is a full
// merge_result_t (645 KB; 64 robots, 2016 pairs with 256-byte verdicts), whose decoding needs ~0.5 MB in one
// block (its 2016 MergePairOutcome; a full pose_update_t's 4096 Eigen::Isometry3d are 0.5 MB too): 2 MB. A full
// merge_round_t carries 2^20 keyframes (4.2 MB on the wire, decoded into one 4 MB int32 block): 16 MB.
//
// Adding a decoder is one row here. tests/fuzz/CMakeLists.txt reads the rows from this file and builds
// cm_fuzz_<name> (fuzz_decoder.cpp with the row selected) and the CTest test "fuzz: <name>"; cm_fuzz_seeds
// writes its seed corpus (realistic messages when seed_corpus.cpp knows the type, else the encoded default
// message). Keep every row on one line, in the form X(lower_case_name, ..., <integer>) \ , above the end marker.
#pragma once

#include "platform/lcm/message_codec.hpp"
#include "platform/lcm/status_codec.hpp"
#include "platform/lcm/input_codec.hpp"
#include "platform/lcm/round_codec.hpp"

// clang-format off
#define CM_FUZZ_CODECS(X)                                                                   \
  X(keyframe_batch,  KeyframeBatch,      DecodeKeyframeBatch,   EncodeKeyframeBatch,  2)    \
  X(pose_update,     PoseUpdate,         DecodePoseUpdate,      EncodePoseUpdate,     2)    \
  X(scan_request,    ScanRequest,        DecodeScanRequest,     EncodeScanRequest,    2)    \
  X(scan_chunk,      ScanChunk,          DecodeScanChunk,       EncodeScanChunk,      2)    \
  X(transfer_status, TransferStatus,     DecodeTransferStatus,  EncodeTransferStatus, 2)    \
  X(merge_result,    MergeResultMessage, DecodeMergeResult,     EncodeMergeResult,    2)    \
  X(round_step,      RoundStep,          DecodeRoundStep,       EncodeRoundStep,      16)   \
  X(robot_status,    RobotStatus,        DecodeRobotStatus,     EncodeRobotStatus,    2)    \
  X(server_status,   ServerStatus,       DecodeServerStatus,    EncodeServerStatus,   2)    \
  X(lidar_scan,      LidarScan,          DecodeLidarScan,       EncodeLidarScan,      8)    \
  X(odometry,        OdometrySample,     DecodeOdometry,        EncodeOdometry,       2)    \
  /* end of the table */
// clang-format on
