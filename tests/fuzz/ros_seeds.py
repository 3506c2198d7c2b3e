#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""Seed corpora of the ROS fuzz targets, written by the official ROS 1 writer (Debian's python3-rosbag and the
genpy message classes): SEEDS/ros1_bag/{none,bz2,lz4}.bag, small bags with PointCloud2, Livox CustomMsg,
Odometry and PoseStamped messages; SEEDS/ros_messages/<kind>.bin, one ROS 1 message of each kind behind the fuzz
target's selector byte (bit 0 the encoding, bits 1-2 the kind: tests/fuzz/fuzz_ros_messages.cpp);
SEEDS/mcap/{plain,chunked,lz4}.mcap, small MCAP files (records laid out here by the MCAP specification; the lz4
chunk by roslz4, an LZ4 frame), as seeds only: the reader's tests against the official MCAP writer are in
tests/apps/ros2_import_test.sh.
Usage: ros_seeds.py SEEDS"""
import io
import os
import struct
import sys
import zlib

import roslz4

import genpy.dynamic
import rosbag
import rospy
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from sensor_msgs import point_cloud2
from sensor_msgs.msg import PointField
from std_msgs.msg import Header

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'apps'))
import ros1_bag_fixture  # noqa: E402  (the Livox .msg text)


def messages():
    stamp = rospy.Time(1700000000, 5000)
    header = Header(seq=3, stamp=stamp, frame_id='lidar')
    fields = [PointField('x', 0, PointField.FLOAT32, 1), PointField('y', 4, PointField.FLOAT32, 1),
              PointField('z', 8, PointField.FLOAT32, 1), PointField('intensity', 12, PointField.FLOAT32, 1),
              PointField('t', 16, PointField.UINT32, 1)]
    cloud = point_cloud2.create_cloud(header, fields, [(1.0 + i, 2.0, -0.5 * i, 7.0, 1000 * i) for i in range(6)])
    classes = genpy.dynamic.generate_dynamic('livox_ros_driver/CustomMsg', ros1_bag_fixture.LIVOX_MSG)
    livox = classes['livox_ros_driver/CustomMsg'](header=header, timebase=stamp.to_nsec(), point_num=3, lidar_id=1,
                                                   rsvd=[0, 0, 0])
    for i in range(3):
        livox.points.append(classes['livox_ros_driver/CustomPoint'](offset_time=100 * i, x=5.0, y=0.1 * i, z=0.2,
                                                                     reflectivity=40, tag=16, line=i))
    odom = Odometry(header=Header(seq=3, stamp=stamp, frame_id='odom'), child_frame_id='body')
    odom.pose.pose.position.x, odom.pose.pose.orientation.z, odom.pose.pose.orientation.w = 1.5, 0.6, 0.8
    pose = PoseStamped(header=Header(seq=3, stamp=stamp, frame_id='map'))
    pose.pose.position.y, pose.pose.orientation.w = -2.0, 1.0
    return stamp, [('pointcloud2', 0, '/points', cloud), ('livox', 2, '/livox/lidar', livox),
                   ('odometry', 4, '/odom', odom), ('posestamped', 6, '/pose', pose)]


MCAP_MAGIC = b'\x89MCAP0\r\n'


def mcap_record(op, content):
    return struct.pack('<BQ', op, len(content)) + content


def mcap_string(text):
    raw = text.encode()
    return struct.pack('<I', len(raw)) + raw


def mcap_file(chunk_compression):
    """Header, a schema, a channel and three CDR messages (in a chunk unless chunk_compression is None), Data End,
    Footer."""
    schema = mcap_record(0x03, struct.pack('<H', 1) + mcap_string('nav_msgs/msg/Odometry') + mcap_string('ros2msg') +
                         mcap_string('std_msgs/Header header\nstring child_frame_id\n'))
    channel = mcap_record(0x04, struct.pack('<HH', 1, 1) + mcap_string('/odom') + mcap_string('cdr') +
                          struct.pack('<I', 0))
    body = schema + channel
    for i in range(3):
        data = b'\x00\x01\x00\x00' + struct.pack('<iI', 1700000000 + i, 500) + mcap_string('odom\0')
        body += mcap_record(0x05, struct.pack('<HIQQ', 1, i, 10 + i, 10 + i) + data)
    out = MCAP_MAGIC + mcap_record(0x01, mcap_string('ros2') + mcap_string('commerge seeds'))
    if chunk_compression is None:
        out += body
    else:
        packed = roslz4.compress(body) if chunk_compression == 'lz4' else body
        out += mcap_record(0x06, struct.pack('<QQQI', 10, 12, len(body), zlib.crc32(body)) +
                           mcap_string(chunk_compression if chunk_compression == 'lz4' else '') +
                           struct.pack('<Q', len(packed)) + packed)
    out += mcap_record(0x0F, struct.pack('<I', 0))
    return out + mcap_record(0x02, struct.pack('<QQI', 0, 0, 0)) + MCAP_MAGIC


def main():
    root = sys.argv[1]
    stamp, msgs = messages()
    os.makedirs(os.path.join(root, 'ros1_bag'), exist_ok=True)
    os.makedirs(os.path.join(root, 'ros_messages'), exist_ok=True)
    for compression in ('none', 'bz2', 'lz4'):
        with rosbag.Bag(os.path.join(root, 'ros1_bag', compression + '.bag'), 'w', compression=compression,
                        chunk_threshold=1024) as bag:
            for _, _, topic, msg in msgs + msgs:
                bag.write(topic, msg, stamp)
    os.makedirs(os.path.join(root, 'mcap'), exist_ok=True)
    for name, compression in (('plain', None), ('chunked', 'none'), ('lz4', 'lz4')):
        with open(os.path.join(root, 'mcap', name + '.mcap'), 'wb') as f:
            f.write(mcap_file(compression))
    for name, selector, _, msg in msgs:
        buf = io.BytesIO()
        msg.serialize(buf)
        with open(os.path.join(root, 'ros_messages', name + '.bin'), 'wb') as f:
            f.write(bytes([selector]) + buf.getvalue())


if __name__ == '__main__':
    main()
