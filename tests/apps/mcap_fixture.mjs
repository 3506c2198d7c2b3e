// SPDX-License-Identifier: BSD-3-Clause
// Writes a ROS 2 recording from a KITTI-layout directory with writers that are not commerge's: MCAP by the official
// MCAP writer (@mcap/core's McapWriter) or a rosbag2 sqlite3 .db3 (better-sqlite3, in the table layout of
// rosbag2's current sqlite3 storage: schema version 4, as rosbag2_storage_sqlite3 writes it since Iron), with
// every message serialized to CDR by Foxglove's ROS 2 serializer (@foxglove/rosmsg2-serialization, definitions
// parsed by @foxglove/rosmsg). MCAP chunks: zstd by @foxglove/wasm-zstd (Foxglove's); lz4 by lz4js (an LZ4 frame
// writer: Foxglove's @foxglove/wasm-lz4 only decompresses). So commerge's own MCAP and db3 readers are tested on
// bytes they did not write. Every scan becomes one cloud message stamped with its times.txt time (plus --t0-s),
// followed by one pose message at the same header stamp (recorded 20 ms later, as the odometry publishes after
// it has processed the scan), as tests/apps/ros1_bag_fixture.py does for ROS 1.
//
// Usage: node mcap_fixture.mjs DIR[:FIRST-LAST] OUT [--format mcap|db3] [--compression none|lz4|zstd]
//          [--scan-type pointcloud2|livox] [--pose-type odometry|posestamped] [--t0-s S] [--chunk-bytes 786432]
//          [--extra-topic] [--modules DIR]
//   pointcloud2: sensor_msgs/msg/PointCloud2 in the Velodyne driver's layout (x y z intensity float32 at 0 4 8 16,
//                ring uint16 at 20, time float32 at 24, 32-byte points), topic /velodyne_points
//   livox:       livox_ros_driver2/msg/CustomMsg (reflectivity = intensity rounded into 0..255), topic /livox/lidar
//   poses:       nav_msgs/msg/Odometry on /odom, or geometry_msgs/msg/PoseStamped on /pose
//   --extra-topic  also writes a std_msgs/msg/String topic /rosout_note that the import must ignore
//   --modules DIR  where node_modules is (default $COMMERGE_NODE_DEPS, else this script's directory); the packages
//                  are pinned in package.json / package-lock.json beside this script
import fs from 'node:fs';
import path from 'node:path';
import { spawnSync } from 'node:child_process';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';

const HEADER = `================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec`;

const POSE = `================================================================================
MSG: geometry_msgs/Pose
Point position
Quaternion orientation
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x 0
float64 y 0
float64 z 0
float64 w 1`;

const DEFINITIONS = {
  'sensor_msgs/msg/PointCloud2': `std_msgs/Header header
uint32 height
uint32 width
PointField[] fields
bool is_bigendian
uint32 point_step
uint32 row_step
uint8[] data
bool is_dense
${HEADER}
================================================================================
MSG: sensor_msgs/PointField
uint8 INT8=1
uint8 UINT8=2
uint8 INT16=3
uint8 UINT16=4
uint8 INT32=5
uint8 UINT32=6
uint8 FLOAT32=7
uint8 FLOAT64=8
string name
uint32 offset
uint8 datatype
uint32 count`,
  'livox_ros_driver2/msg/CustomMsg': `std_msgs/Header header
uint64 timebase
uint32 point_num
uint8 lidar_id
uint8[3] rsvd
CustomPoint[] points
${HEADER}
================================================================================
MSG: livox_ros_driver2/CustomPoint
uint32 offset_time
float32 x
float32 y
float32 z
uint8 reflectivity
uint8 tag
uint8 line`,
  'nav_msgs/msg/Odometry': `std_msgs/Header header
string child_frame_id
geometry_msgs/PoseWithCovariance pose
geometry_msgs/TwistWithCovariance twist
${HEADER}
================================================================================
MSG: geometry_msgs/PoseWithCovariance
Pose pose
float64[36] covariance
${POSE}
================================================================================
MSG: geometry_msgs/TwistWithCovariance
Twist twist
float64[36] covariance
================================================================================
MSG: geometry_msgs/Twist
Vector3 linear
Vector3 angular
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z`,
  'geometry_msgs/msg/PoseStamped': `std_msgs/Header header
geometry_msgs/Pose pose
${HEADER}
${POSE}`,
  'std_msgs/msg/String': 'string data',
};

function usage(message) {
  process.stderr.write(`mcap_fixture.mjs: ${message}\n`);
  process.exit(2);
}

function parseArgs(argv) {
  const a = { format: 'mcap', compression: 'none', scanType: 'pointcloud2', poseType: 'odometry', t0: null,
              chunkBytes: 768 * 1024, extraTopic: false, modules: null, positional: [] };
  const choices = { '--format': ['format', ['mcap', 'db3']], '--compression': ['compression', ['none', 'lz4', 'zstd']],
                    '--scan-type': ['scanType', ['pointcloud2', 'livox']],
                    '--pose-type': ['poseType', ['odometry', 'posestamped']] };
  for (let i = 0; i < argv.length; ++i) {
    const arg = argv[i];
    if (choices[arg]) {
      const [key, allowed] = choices[arg];
      if (!allowed.includes(argv[i + 1])) usage(`${arg} wants one of ${allowed.join(', ')}`);
      a[key] = argv[++i];
    } else if (arg === '--t0-s') {
      a.t0 = Number(argv[++i]);
    } else if (arg === '--chunk-bytes') {
      a.chunkBytes = Number(argv[++i]);
    } else if (arg === '--modules') {
      a.modules = argv[++i];
    } else if (arg === '--extra-topic') {
      a.extraTopic = true;
    } else if (arg.startsWith('--')) {
      usage(`unknown option ${arg}`);
    } else {
      a.positional.push(arg);
    }
  }
  if (a.positional.length !== 2) usage('want DIR[:FIRST-LAST] OUT');
  return a;
}

function loadModules(dir) {
  const require = createRequire(path.join(path.resolve(dir), 'package.json'));
  return {
    McapWriter: require('@mcap/core').McapWriter,
    parse: require('@foxglove/rosmsg').parse,
    MessageWriter: require('@foxglove/rosmsg2-serialization').MessageWriter,
    zstd: require('@foxglove/wasm-zstd'),
    lz4js: require('lz4js'),
  };
}

// ---- The KITTI-layout input --------------------------------------------------------------------------------------

function readDataset(spec) {
  let dir = spec, first = 0, last = null;
  const colon = spec.lastIndexOf(':');
  if (colon > 0 && spec.slice(colon + 1).includes('-')) {
    dir = spec.slice(0, colon);
    [first, last] = spec.slice(colon + 1).split('-').map(Number);
  }
  const scans = fs.readdirSync(path.join(dir, 'velodyne')).filter((f) => f.endsWith('.bin')).sort();
  const poses = fs.readFileSync(path.join(dir, 'poses.txt'), 'utf8').split('\n')
    .map((l) => l.trim().split(/\s+/).map(Number)).filter((v) => v.length === 12);
  const times = fs.readFileSync(path.join(dir, 'times.txt'), 'utf8').split(/\s+/).filter((x) => x).map(Number);
  last = last === null ? scans.length : last;
  if (scans.length !== poses.length || poses.length !== times.length || !(first >= 0 && first < last &&
      last <= scans.length)) {
    usage(`${dir}: ${scans.length} scans, ${poses.length} poses, ${times.length} times, range ${first}-${last}`);
  }
  return { dir, scans, poses, times, first, last };
}

/// (x, y, z, w) of the rotation in the row-major 3x4 [R|t] v (Shepperd's method, as ros1_bag_fixture.py).
function quaternionOf(v) {
  const r = [[v[0], v[1], v[2]], [v[4], v[5], v[6]], [v[8], v[9], v[10]]];
  const tr = r[0][0] + r[1][1] + r[2][2];
  if (tr > 0) {
    const s = Math.sqrt(tr + 1.0) * 2;
    return [(r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s, (r[1][0] - r[0][1]) / s, 0.25 * s];
  }
  let i = 0;
  for (let k = 1; k < 3; ++k) if (r[k][k] > r[i][i]) i = k;
  const j = (i + 1) % 3, k = (i + 2) % 3;
  const s = Math.sqrt(1.0 + r[i][i] - r[j][j] - r[k][k]) * 2;
  const q = [0, 0, 0, 0];
  q[i] = 0.25 * s;
  q[j] = (r[j][i] + r[i][j]) / s;
  q[k] = (r[k][i] + r[i][k]) / s;
  q[3] = (r[k][j] - r[j][k]) / s;
  return q;
}

// ---- Messages ----------------------------------------------------------------------------------------------------

/// rospy.Time.from_sec's split (sec truncated, nanoseconds truncated), as the ROS 1 fixture stamps.
function stampOf(seconds) {
  const sec = Math.trunc(seconds);
  const nanosec = Math.trunc((seconds - sec) * 1e9);
  return { sec, nanosec, ns: BigInt(sec) * 1000000000n + BigInt(nanosec) };
}

function velodyneCloud(header, raw, periodS) {
  const n = raw.length / 16;
  const data = new Uint8Array(32 * n);
  const out = new DataView(data.buffer);
  for (let i = 0; i < n; ++i) {
    data.set(raw.subarray(16 * i, 16 * i + 12), 32 * i);      // x y z: the file's float32 bits
    data.set(raw.subarray(16 * i + 12, 16 * i + 16), 32 * i + 16);  // intensity
    out.setUint16(32 * i + 20, i % 16, true);
    out.setFloat32(32 * i + 24, periodS * i / Math.max(n, 1), true);
  }
  const field = (name, offset, datatype) => ({ name, offset, datatype, count: 1 });
  return { header, height: 1, width: n, is_bigendian: false, point_step: 32, row_step: 32 * n, data,
           fields: [field('x', 0, 7), field('y', 4, 7), field('z', 8, 7), field('intensity', 16, 7),
                    field('ring', 20, 4), field('time', 24, 7)], is_dense: true };
}

function livoxCloud(header, raw, stampNs, periodS) {
  const n = raw.length / 16;
  const view = new DataView(raw.buffer, raw.byteOffset, raw.byteLength);
  const points = [];
  for (let i = 0; i < n; ++i) {
    const f = (k) => view.getFloat32(16 * i + 4 * k, true);
    points.push({ offset_time: Math.trunc(periodS * 1e9 * i / Math.max(n, 1)), x: f(0), y: f(1), z: f(2),
                  reflectivity: Math.max(0, Math.min(255, Math.round(f(3)))), tag: 0x10, line: i % 6 });
  }
  return { header, timebase: stampNs, point_num: n, lidar_id: 0, rsvd: [0, 0, 0], points };
}

function poseMessage(kind, header, v) {
  const [x, y, z, w] = quaternionOf(v);
  const pose = { position: { x: v[3], y: v[7], z: v[11] }, orientation: { x, y, z, w } };
  if (kind === 'posestamped') return { header, pose };
  const zero = { x: 0, y: 0, z: 0 };
  return { header, child_frame_id: 'body', pose: { pose, covariance: new Array(36).fill(0) },
           twist: { twist: { linear: zero, angular: zero }, covariance: new Array(36).fill(0) } };
}

/// The recording's messages in time order: { topic, type, logNs, message }.
function* messagesOf(a, ds) {
  const t0 = a.t0 !== null ? a.t0 : (ds.times[ds.first] < 1e8 ? 1.7e9 : 0);
  for (let k = ds.first; k < ds.last; ++k) {
    const stamp = stampOf(t0 + ds.times[k]);
    const raw = new Uint8Array(fs.readFileSync(path.join(ds.dir, 'velodyne', ds.scans[k])));
    const header = { stamp: { sec: stamp.sec, nanosec: stamp.nanosec }, frame_id: 'lidar' };
    if (a.scanType === 'livox') {
      yield { topic: '/livox/lidar', type: 'livox_ros_driver2/msg/CustomMsg', logNs: stamp.ns,
              message: livoxCloud(header, raw, stamp.ns, 0.1) };
    } else {
      yield { topic: '/velodyne_points', type: 'sensor_msgs/msg/PointCloud2', logNs: stamp.ns,
              message: velodyneCloud(header, raw, 0.1) };
    }
    const recv = stamp.ns + 20000000n;
    const poseHeader = { stamp: header.stamp, frame_id: 'odom' };
    const odometry = a.poseType === 'odometry';
    yield { topic: odometry ? '/odom' : '/pose',
            type: odometry ? 'nav_msgs/msg/Odometry' : 'geometry_msgs/msg/PoseStamped', logNs: recv, message: poseMessage(a.poseType, poseHeader, ds.poses[k]) };
    if (a.extraTopic) {
      yield { topic: '/rosout_note', type: 'std_msgs/msg/String', logNs: recv, message: { data: `scan ${k}` } };
    }
  }
}

// ---- Writers -----------------------------------------------------------------------------------------------------

class Serializers {
  constructor(m) {
    this.m = m;
    this.writers = new Map();
  }
  write(type, message) {
    if (!this.writers.has(type)) {
      this.writers.set(type, new this.m.MessageWriter(this.m.parse(DEFINITIONS[type], { ros2: true })));
    }
    return this.writers.get(type).writeMessage(message);
  }
}

async function writeMcap(m, a, ds, out) {
  const fd = fs.openSync(out, 'w');
  let pos = 0n;
  const sink = { position: () => pos,
                 write: async (buffer) => { fs.writeSync(fd, buffer); pos += BigInt(buffer.byteLength); } };
  let compressChunk;
  if (a.compression === 'zstd') {
    await m.zstd.isLoaded;
    compressChunk = (data) => ({ compression: 'zstd', compressedData: m.zstd.compress(data, 3) });
  } else if (a.compression === 'lz4') {
    compressChunk = (data) => ({ compression: 'lz4', compressedData: Uint8Array.from(m.lz4js.compress(data)) });
  }
  const writer = new m.McapWriter({ writable: sink, useStatistics: true, useChunks: true, useChunkIndex: true,
                                    useMessageIndex: true, chunkSize: a.chunkBytes, compressChunk });
  await writer.start({ profile: 'ros2', library: 'commerge tests/apps/mcap_fixture.mjs (@mcap/core)' });
  const serializers = new Serializers(m);
  const channels = new Map();
  const sequence = new Map();
  for (const msg of messagesOf(a, ds)) {
    if (!channels.has(msg.topic)) {
      const schemaId = await writer.registerSchema({ name: msg.type, encoding: 'ros2msg',
                                                     data: new TextEncoder().encode(DEFINITIONS[msg.type]) });
      channels.set(msg.topic, await writer.registerChannel({ schemaId, topic: msg.topic, messageEncoding: 'cdr',
                                                             metadata: new Map() }));
    }
    const seq = (sequence.get(msg.topic) || 0) + 1;
    sequence.set(msg.topic, seq);
    await writer.addMessage({ channelId: channels.get(msg.topic), sequence: seq, logTime: msg.logNs,
                              publishTime: msg.logNs, data: serializers.write(msg.type, msg.message) });
  }
  await writer.end();
  fs.closeSync(fd);
}

// A rosbag2 .db3: the CDR messages go to tests/apps/rosbag2_db3_writer.py, which writes them with Python's sqlite3
// module in rosbag2's table layout (schema version 4).
function writeDb3(m, a, ds, out, here) {
  const serializers = new Serializers(m);
  const parts = [];
  for (const msg of messagesOf(a, ds)) {
    const data = Buffer.from(serializers.write(msg.type, msg.message));
    const body = Buffer.concat([Buffer.from(`${msg.topic}\0${msg.type}\0${DEFINITIONS[msg.type]}\0${msg.logNs}\0`), data]);
    const head = Buffer.alloc(4);
    head.writeUInt32LE(body.length);
    parts.push(head, body);
  }
  const r = spawnSync('/usr/bin/python3', [path.join(here, 'rosbag2_db3_writer.py'), out],
                      { input: Buffer.concat(parts), stdio: ['pipe', 'inherit', 'inherit'] });
  if (r.status !== 0) throw new Error(`rosbag2_db3_writer.py ${out} failed (exit ${r.status})`);
}

async function main() {
  const a = parseArgs(process.argv.slice(2));
  const here = path.dirname(fileURLToPath(import.meta.url));
  const m = loadModules(a.modules || process.env.COMMERGE_NODE_DEPS || here);
  const ds = readDataset(a.positional[0]);
  if (a.format === 'db3') {
    if (a.compression !== 'none') usage('--compression applies to --format mcap only');
    writeDb3(m, a, ds, a.positional[1], here);
  } else {
    await writeMcap(m, a, ds, a.positional[1]);
  }
}

main().catch((e) => {
  process.stderr.write(`mcap_fixture.mjs: ${e.stack || e}\n`);
  process.exit(1);
});
