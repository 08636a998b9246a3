"""Reads a run.mcap with Foxglove's own Python readers (mcap, mcap-protobuf-support) and prints
one JSON object: per topic its schema and message count, the compressions of the file's chunks,
and the LaserScan of one UAV whose stamp is a given sim time (ranges as floats, +inf as null,
since JSON has no infinity).

usage: read_mcap.py RUN.mcap UAV_ID T_SECS
"""
import json
import math
import sys

from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory


def main():
    path, uav, t_secs = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
    want_ns = round(t_secs * 1e9)
    topics = {}
    scan = None
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        compressions = sorted({c.compression for c in reader.get_summary().chunk_indexes})
        f.seek(0)
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message in reader.iter_messages():
            t = topics.setdefault(
                channel.topic,
                {"schema": schema.name if schema else None, "encoding": channel.message_encoding, "count": 0},
            )
            t["count"] += 1
        f.seek(0)
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _schema, _channel, message, scan_msg in reader.iter_decoded_messages(topics=[f"/uav/{uav}/scan"]):
            stamp_ns = scan_msg.timestamp.seconds * 10**9 + scan_msg.timestamp.nanos
            if message.log_time == want_ns and stamp_ns == want_ns:
                scan = {
                    "frame_id": scan_msg.frame_id,
                    "start_angle": scan_msg.start_angle,
                    "end_angle": scan_msg.end_angle,
                    "ranges": [None if math.isinf(r) else r for r in scan_msg.ranges],
                }
    print(json.dumps({"topics": topics, "chunk_compressions": compressions, "scan": scan}))


if __name__ == "__main__":
    main()
