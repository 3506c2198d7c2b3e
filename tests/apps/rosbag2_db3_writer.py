#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""Writes a rosbag2 sqlite3 file (.db3) with Python's sqlite3 module (SQLite's own library), in the table layout of
rosbag2's sqlite3 storage at schema version 4 (rosbag2_storage_sqlite3 since Iron). The messages come on stdin,
already CDR-serialized by Foxglove's @foxglove/rosmsg2-serialization (tests/apps/mcap_fixture.mjs --format db3):
a sequence of records, each a little-endian uint32 byte count and that many bytes of
    topic \\0 type \\0 definition \\0 decimal log time [ns] \\0 CDR message
Usage: rosbag2_db3_writer.py OUT.db3 < records"""
import os
import sqlite3
import struct
import sys

SCHEMA = """
CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL, metadata TEXT NOT NULL);
CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
                    serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL,
                    type_description_hash TEXT NOT NULL);
CREATE TABLE message_definitions(id INTEGER PRIMARY KEY, topic_type TEXT NOT NULL, encoding TEXT NOT NULL,
                                 encoded_message_definition TEXT NOT NULL, type_description_hash TEXT NOT NULL);
CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL,
                      data BLOB NOT NULL);
CREATE INDEX timestamp_idx ON messages (timestamp ASC);
INSERT INTO schema (schema_version, ros_distro) VALUES (4, 'jazzy');
"""


def records(stream):
    while True:
        head = stream.read(4)
        if not head:
            return
        (n,) = struct.unpack('<I', head)
        body = stream.read(n)
        if len(body) != n:
            sys.exit('rosbag2_db3_writer.py: a record of %d bytes ends after %d' % (n, len(body)))
        topic, type_, definition, log_ns, data = body.split(b'\0', 4)
        yield topic.decode(), type_.decode(), definition.decode(), int(log_ns), data


def main():
    out = sys.argv[1]
    if os.path.exists(out):
        os.remove(out)
    db = sqlite3.connect(out)
    db.executescript(SCHEMA)
    topics, count = {}, 0
    for topic, type_, definition, log_ns, data in records(sys.stdin.buffer):
        if topic not in topics:
            cur = db.execute('INSERT INTO topics (name, type, serialization_format, offered_qos_profiles, '
                             'type_description_hash) VALUES (?, ?, ?, ?, ?)', (topic, type_, 'cdr', '', ''))
            topics[topic] = cur.lastrowid
            db.execute('INSERT INTO message_definitions (topic_type, encoding, encoded_message_definition, '
                       'type_description_hash) VALUES (?, ?, ?, ?)', (type_, 'ros2msg', definition, ''))
        db.execute('INSERT INTO messages (timestamp, topic_id, data) VALUES (?, ?, ?)', (log_ns, topics[topic], data))
        count += 1
    db.execute('INSERT INTO metadata (metadata_version, metadata) VALUES (?, ?)',
               (9, 'rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: sqlite3\n'
                   '  message_count: %d\n' % count))
    db.commit()
    db.close()


if __name__ == '__main__':
    main()
