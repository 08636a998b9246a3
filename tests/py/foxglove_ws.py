"""A small Foxglove WebSocket client (written from the protocol's spec, none of our code). It
offers the subprotocol names given (default: the protocol's old name, foxglove.websocket.v1, and
its current one, foxglove.sdk.v1; Lichtblick offers only the old one), subscribes to one topic,
decodes its messages with the protobuf schema the server advertises, and prints one JSON object
with what it received and the subprotocol the server chose.

usage: foxglove_ws.py ws://HOST:PORT TOPIC COUNT TIMEOUT_S [NAME,NAME...]
"""
import base64
import json
import struct
import sys
import time

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from websockets.sync.client import connect


def message_class(schema_name, schema_b64):
    fds = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(schema_b64))
    pool = descriptor_pool.DescriptorPool()
    for f in fds.file:
        pool.Add(f)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema_name))


def main():
    url, topic, want, timeout = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4])
    offers = sys.argv[5].split(",") if len(sys.argv) > 5 else ["foxglove.websocket.v1", "foxglove.sdk.v1"]
    deadline = time.monotonic() + timeout
    out = {"server": None, "channel": None, "poses": []}
    cls = None
    with connect(url, subprotocols=offers, open_timeout=timeout) as ws:
        out["subprotocol"] = ws.subprotocol
        while len(out["poses"]) < want and time.monotonic() < deadline:
            try:
                msg = ws.recv(timeout=max(0.1, deadline - time.monotonic()))
            except TimeoutError:
                break
            if isinstance(msg, str):
                m = json.loads(msg)
                if m.get("op") == "serverInfo":
                    out["server"] = m.get("name")
                elif m.get("op") == "advertise" and cls is None:
                    for ch in m["channels"]:
                        if ch["topic"] == topic:
                            out["channel"] = {k: ch[k] for k in ("topic", "encoding", "schemaName")}
                            cls = message_class(ch["schemaName"], ch["schema"])
                            ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 7, "channelId": ch["id"]}]}))
            elif msg and msg[0] == 0x01:
                # messageData: opcode u8, subscription id u32 LE, log time u64 LE, payload.
                sub, log_time = struct.unpack_from("<IQ", msg, 1)
                if sub != 7 or cls is None:
                    continue
                p = cls.FromString(msg[13:])
                pos = p.pose.position
                out["poses"].append({"log_time_ns": log_time, "frame_id": p.frame_id, "x": pos.x, "y": pos.y})
    print(json.dumps(out))


if __name__ == "__main__":
    main()
