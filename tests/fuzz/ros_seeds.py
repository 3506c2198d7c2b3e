#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""Seed corpora of the ROS fuzz targets, written by the official ROS 1 writer (Debian's python3-rosbag and the
genpy message classes): SEEDS/ros1_bag/{none,bz2,lz4}.bag, small bags with PointCloud2, Livox CustomMsg,
Odometry and PoseStamped messages; SEEDS/ros_messages/<kind>.bin, one ROS 1 message of each kind behind the fuzz
target's selector byte (bit 0 the encoding, bits 1-2 the kind: tests/fuzz/fuzz_ros_messages.cpp);
SEEDS/mcap/{plain,chunked,lz4}.mcap, small MCAP files (records laid out here by the MCAP specification; the lz4
chunk by roslz4, an LZ4 frame), as seeds only: the reader's tests against the official MCAP writer are in
tests/apps/ros2_import_test.sh; SEEDS/rosbag2_db3/odom.db3, a tiny rosbag2 sqlite3 file (Python's sqlite3, in the
schema of tests/apps/rosbag2_db3_writer.py) with one nav_msgs/msg/Odometry topic and two small CDR-looking
messages; SEEDS/pcd/{ascii,binary,pcl_binary_compressed}.pcd, point clouds (FIELDS x y z intensity; the
binary_compressed one is the bytes of a file written by PCL, copied from tests/platform/io/test_pcd_compressed.cpp).
Usage: ros_seeds.py SEEDS"""
import io
import os
import sqlite3
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
import rosbag2_db3_writer  # noqa: E402  (rosbag2's sqlite3 schema)


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


def rosbag2_db3(path):
    """One topic /odom (nav_msgs/msg/Odometry, cdr) and two small CDR-looking messages (an encapsulation header,
    then the start of a std_msgs/Header: stamp, frame_id)."""
    if os.path.exists(path):
        os.remove(path)
    db = sqlite3.connect(path)
    db.execute('PRAGMA page_size = 512')  # SQLite's smallest page: a 3.5 KB file (7 pages) rather than 28 KB
    db.executescript(rosbag2_db3_writer.SCHEMA)
    cur = db.execute('INSERT INTO topics (name, type, serialization_format, offered_qos_profiles, '
                     'type_description_hash) VALUES (?, ?, ?, ?, ?)', ('/odom', 'nav_msgs/msg/Odometry', 'cdr', '', ''))
    db.execute('INSERT INTO message_definitions (topic_type, encoding, encoded_message_definition, '
               'type_description_hash) VALUES (?, ?, ?, ?)',
               ('nav_msgs/msg/Odometry', 'ros2msg', 'std_msgs/Header header\nstring child_frame_id\n', ''))
    for i in range(2):
        data = b'\x00\x01\x00\x00' + struct.pack('<iI', 1700000000 + i, 500) + mcap_string('odom\0')
        db.execute('INSERT INTO messages (timestamp, topic_id, data) VALUES (?, ?, ?)',
                   (1700000000000000500 + i * 100000000, cur.lastrowid, data))
    db.execute('INSERT INTO metadata (metadata_version, metadata) VALUES (?, ?)',
               (9, 'rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: sqlite3\n  message_count: 2\n'))
    db.commit()
    db.close()


PCD_POINTS = [(1.5, -2.25, 3.0, 0.5), (0.1, 100.125, -7.0, 255.0), (-4.0, 0.0, 0.25, 12.0)]


def pcd_header(data):
    return ('# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\n'
            'TYPE F F F F\nCOUNT 1 1 1 1\nWIDTH %d\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\nDATA %s\n'
            % (len(PCD_POINTS), len(PCD_POINTS), data)).encode()


# A file written by PCL 1.13 (pcl_convert_pcd_ascii_binary xyzi.pcd xyzi_c.pcd 2): its header and data block are
# kPclXyziHeader and kPclXyziBlock of tests/platform/io/test_pcd_compressed.cpp (5 points, one of them NaN), then
# PCL's zero padding to 4096 bytes.
PCL_XYZI_HEADER = (b'# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z intensity\n'
                   b'SIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 5\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n'
                   b'POINTS 5\nDATA binary_compressed\n')
PCL_XYZI_BLOCK = bytes([
    0x39, 0x00, 0x00, 0x00, 0x50, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0xc0, 0x3f, 0x00, 0xa0, 0x03,
    0x03, 0xcd, 0xcc, 0xcc, 0x3d, 0x20, 0x0b, 0x04, 0x7f, 0x00, 0x00, 0x10, 0xc0, 0xe0, 0x00, 0x03,
    0x04, 0x40, 0xc8, 0x42, 0x00, 0x00, 0x40, 0x13, 0x02, 0x40, 0x40, 0x00, 0xe0, 0x00, 0x03, 0x00,
    0xe0, 0x20, 0x1f, 0x40, 0x13, 0x00, 0x00, 0x20, 0x3b, 0xc0, 0x03, 0x02, 0x7f, 0x43, 0x00, 0x20,
    0x00,
])


def pcd_files():
    """(name, bytes) of the PCD seeds."""
    ascii_rows = ''.join('%r %r %r %r\n' % p for p in PCD_POINTS).encode()
    binary_rows = b''.join(struct.pack('<4f', *p) for p in PCD_POINTS)
    pcl = PCL_XYZI_HEADER + PCL_XYZI_BLOCK
    return [('ascii.pcd', pcd_header('ascii') + ascii_rows), ('binary.pcd', pcd_header('binary') + binary_rows),
            ('pcl_binary_compressed.pcd', pcl + bytes(4096 - len(pcl)))]


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
    os.makedirs(os.path.join(root, 'rosbag2_db3'), exist_ok=True)
    rosbag2_db3(os.path.join(root, 'rosbag2_db3', 'odom.db3'))
    os.makedirs(os.path.join(root, 'pcd'), exist_ok=True)
    for name, data in pcd_files():
        with open(os.path.join(root, 'pcd', name), 'wb') as f:
            f.write(data)


if __name__ == '__main__':
    main()
