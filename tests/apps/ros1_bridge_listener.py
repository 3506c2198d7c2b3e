#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""A ROS 1 subscriber for tests/apps/ros1_bridge_test.sh: what rviz would see of commerge-ros1-bridge's way back.
Waits (at most --timeout-s) for
  - a tf2_msgs/TFMessage on /tf_static holding WORLD -> CHILD whose transform equals the server's T_world_map of
    --robot in --transforms (transforms.txt, rows "robot <id> merged <3x4 row-major>") within 1 mm / 1e-3,
  - a sensor_msgs/PointCloud2 on --map-topic in frame WORLD with x, y, z fields and exactly --map-points points
    (the server's final merged_map.pcd).
Prints what it received; exit 0 when both arrived, 1 otherwise.

Usage: ros1_bridge_listener.py --child robot_1/map --robot 1 --transforms server/transforms.txt --map-points N
                               [--world world] [--map-topic /commerge/merged_map] [--timeout-s 30]
"""
import argparse
import math
import sys
import threading

import rospy
from sensor_msgs.msg import PointCloud2
from tf2_msgs.msg import TFMessage


def server_transform(path, robot):
    with open(path) as f:
        for line in f:
            v = line.split()
            if len(v) == 15 and v[0] == 'robot' and v[1] == str(robot) and v[2] == 'merged':
                return [float(x) for x in v[3:]]
    sys.exit('ros1_bridge_listener.py: %s holds no "robot %d merged" row' % (path, robot))


def matrix_of(t):
    """Row-major 3x4 [R|t] of a geometry_msgs/Transform."""
    q, p = t.rotation, t.translation
    w, x, y, z = q.w, q.x, q.y, q.z
    r = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    return [r[0][0], r[0][1], r[0][2], p.x, r[1][0], r[1][1], r[1][2], p.y, r[2][0], r[2][1], r[2][2], p.z]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('--child', required=True)
    ap.add_argument('--robot', type=int, required=True)
    ap.add_argument('--transforms', required=True)
    ap.add_argument('--map-points', type=int, required=True)
    ap.add_argument('--world', default='world')
    ap.add_argument('--map-topic', default='/commerge/merged_map')
    ap.add_argument('--timeout-s', type=float, default=30.0)
    a = ap.parse_args(rospy.myargv()[1:])
    expected = server_transform(a.transforms, a.robot)

    done = threading.Event()
    state = {'tf': None, 'map': None, 'maps_seen': []}

    def check():
        if state['tf'] is not None and state['map'] is not None:
            done.set()

    def on_tf(msg):
        for t in msg.transforms:
            if t.header.frame_id != a.world or t.child_frame_id != a.child:
                continue
            got = matrix_of(t.transform)
            err = max(abs(g - e) for g, e in zip(got, expected))
            print('tf %s -> %s: translation %.3f %.3f %.3f m, largest difference to transforms.txt %.2g' %
                  (a.world, a.child, got[3], got[7], got[11], err), flush=True)
            if err <= 1e-3:
                state['tf'] = got
        check()

    def on_map(msg):
        names = [f.name for f in msg.fields]
        points = msg.width * msg.height
        state['maps_seen'].append(points)
        print('map on %s: frame %s, %d points, fields %s' % (a.map_topic, msg.header.frame_id, points,
                                                            ' '.join(names)), flush=True)
        if msg.header.frame_id == a.world and {'x', 'y', 'z'} <= set(names) and points == a.map_points and \
                len(msg.data) == msg.row_step * msg.height:
            state['map'] = points
        check()

    rospy.init_node('commerge_bridge_listener', anonymous=True, disable_signals=True)
    rospy.Subscriber('/tf_static', TFMessage, on_tf)
    rospy.Subscriber(a.map_topic, PointCloud2, on_map)
    ok = done.wait(a.timeout_s)
    rospy.signal_shutdown('done')
    if not ok:
        print('ros1_bridge_listener.py: after %.0f s: tf %s -> %s %s; map with %d points %s (maps seen: %s)' %
              (a.timeout_s, a.world, a.child, 'received' if state['tf'] else 'MISSING or wrong', a.map_points,
               'received' if state['map'] else 'MISSING', state['maps_seen']), file=sys.stderr, flush=True)
        return 1
    print('ros1_bridge_listener.py: received tf %s -> %s and the merged map (%d points)' %
          (a.world, a.child, state['map']), flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
