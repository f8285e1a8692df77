#!/usr/bin/env python3
"""Writes the generated seed inputs of fuzz/corpus (small files, committed; rerun after a format
change): every message of the scene protocol (docs/protocol.md), session scripts for
session_fuzz (its op codes are in fuzz/session_fuzz.cpp), logs with and without damage
(docs/log-format.md), and reduced body models and calibrations derived from the seeds already
there. Hand-made seeds in the same folders are kept."""
import json
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
CORPUS = os.path.join(HERE, "corpus")
VERSION = 2


def write(folder, name, data):
    os.makedirs(os.path.join(CORPUS, folder), exist_ok=True)
    with open(os.path.join(CORPUS, folder, name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


# ---- scene protocol ----

def packet(msg_type, payload):
    return struct.pack("<BBBBI", ord("M"), VERSION, msg_type, 0, len(payload)) + payload


def hello(role, caps=5, token=b"\0" * 16, name=b"fuzz", secret=b"", lod=255):
    return packet(1, struct.pack("<BBBBI", VERSION, VERSION, role, lod, caps) + token +
                  bytes([len(name)]) + name + bytes([len(secret)]) + secret)


def welcome(token, resumed=0):
    return packet(2, struct.pack("<BBHI", VERSION, resumed, 0, 13) + token + struct.pack("<I", 7))


def model(slot, dofs, name=b"alice", body=b"{}"):
    return packet(10, struct.pack("<HIHBB", slot, 0, dofs, len(name), 0) + name + struct.pack("<I", len(body)) + body)


def pose(slot, seq, dofs, flags=0):
    return packet(20, struct.pack("<HHIQ", slot, flags, seq, 1_700_000_000_000_000) + struct.pack("<iii", 0, 90000, 0) +
                  struct.pack("<hhhh", 0, 0, 0, 32767) + struct.pack("<H", dofs) + b"".join(
                      struct.pack("<h", (i * 977) % 20000 - 10000) for i in range(dofs)))


def udp_register(token, nonce):
    return packet(5, token + struct.pack("<Q", nonce))


TOKEN = bytes(range(1, 17))
net = {
    "hello_publisher_secret": hello(1, secret=b"s3cret"),
    "hello_subscriber_udp_mesh": hello(2, caps=0xF, lod=1),
    "hello_resume": hello(2, token=TOKEN),
    "hello_control_name": hello(1, name=b"\x1b]0;x\x07"),
    "welcome": welcome(TOKEN, 1),
    "reject": packet(3, struct.pack("<HBBB", 13, VERSION, VERSION, 4) + b"idle"),
    "bye": packet(4, b""),
    "ping": packet(6, b""),
    "udp_register_first": udp_register(TOKEN, 0),
    "udp_register_echo": udp_register(TOKEN, 0x1122334455667788),
    "model_52": model(0, 52),
    "removed": packet(11, struct.pack("<H", 3)),
    "scene": packet(12, struct.pack("<H", 2) + struct.pack("<HI", 1, 1) + struct.pack("<HI", 2, 5)),
    "pose_52_stale": pose(0, 9, 52, 1),
    "pose_0": pose(1, 1, 0),
    "mesh_topology": packet(30, struct.pack("<HBII", 1, 0, 3, 3) + struct.pack("<III", 0, 1, 2)),
    "mesh": packet(31, struct.pack("<HBBIQ", 1, 0, 0, 1, 5) + struct.pack("<ffff", 0, 0, 0, 0.001) +
                   struct.pack("<I", 3) + struct.pack("<9H", *range(9))),
    "stream_publisher": hello(1) + model(0, 4) + pose(0, 1, 4) + pose(0, 2, 4) + packet(6, b"") + packet(4, b""),
}
for k, v in net.items():
    write("net", k, v)

# ---- session scripts (op codes of session_fuzz.cpp) ----
CONNECT, RAW, HELLO, MODEL, POSE, PING_BYE, UDP, CLOSE, FLOOD = range(9)
session = {
    # subscriber with UDP: connect, HELLO, register, echo the nonce
    "subscriber_udp": bytes([CONNECT, 0, HELLO, 0, 0x00, 0x0F, UDP, 0, 0, 0, UDP, 0, 0, 1]),
    # publisher: model, poses, subscriber joins, publisher drops and resumes
    "publisher_resume": bytes([CONNECT, 0, HELLO, 0, 0x01, 0x05, MODEL, 0, 0, 4, 2, POSE, 0, 4, 0, 1, POSE, 0, 4, 0, 2,
                               CONNECT, 0, HELLO, 1, 0x00, 0x05, CLOSE, 0, CONNECT, 0, HELLO, 2, 0x05, 0x05, 0]),
    # a flood of pings, then BYE
    "flood": bytes([CONNECT, 0, HELLO, 0, 0x00, 0x05, FLOOD, 0, FLOOD, 0, FLOOD, 0, PING_BYE, 0, 1]),
    # raw junk before HELLO, and a name with control characters
    "junk_and_bad_name": bytes([CONNECT, 0, RAW, 0, 6, ord("G"), ord("E"), ord("T"), 32, ord("/"), 10,
                                CONNECT, 0, HELLO, 1, 0x08, 0x01]),
    # many connections, half closed
    "many": bytes([CONNECT, 0] * 8 + [HELLO, 0, 0, 5, HELLO, 1, 1, 5, CLOSE, 2, CLOSE, 3, HELLO, 4, 0, 13]),
}
for k, v in session.items():
    write("session", k, v)

# ---- logs ----
MAGIC = b"\x89MLG\r\n\x1a\n"


def record(rtype, payload):
    head = struct.pack("<IB", len(payload), rtype) + payload
    return head + struct.pack("<I", zlib.crc32(head) & 0xFFFFFFFF)


def sample(i):
    return record(2, struct.pack("<HII", i % 3, 1, 0) + struct.pack("<dd", i * 0.01, i * 0.01) +
                  struct.pack("<fffffff", 0.1 * i, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0))


header = json.dumps({"format": "mimic-log", "source": "sim:idle?sensors=3", "rate_hz": 100.0,
                     "sensors": [{"id": 0, "name": "head"}, {"id": 1, "name": "l_hand"}, {"id": 2, "name": "r_hand"}]})
base = MAGIC + struct.pack("<I", 1) + record(1, header.encode())
body = b"".join(sample(i) for i in range(12))
raw = record(3, struct.pack("<Bd", 0, 0.05) + b"\x80\x01\x02")
end = record(4, struct.pack("<Q", 12))
whole = base + body[:6 * 63] + raw + body[6 * 63:] + end
write("log", "small_with_raw.mlog", whole)
flipped = bytearray(whole)
flipped[len(base) + 3 * 63 + 20] ^= 0x10
write("log", "flipped_bit.mlog", bytes(flipped))
garbage = bytearray(whole)
garbage[len(base) + 2 * 63 + 5: len(base) + 2 * 63 + 100] = bytes((i * 37) & 255 for i in range(95))
write("log", "garbage_stretch.mlog", bytes(garbage))
write("log", "no_end_record.mlog", base + body)
write("log", "bad_length.mlog", base + body[:63] + b"\xff\xff\xff\x7f" + body[67:] + end)

# ---- body models and calibrations, reduced from the seeds there ----
with open(os.path.join(CORPUS, "body", "default.json")) as f:
    body_model = json.load(f)
one = dict(body_model, primitives=body_model["primitives"][:1])
write("body", "one_primitive.json", json.dumps(one))
write("body", "three_primitives.json", json.dumps(dict(body_model, primitives=body_model["primitives"][:3])))
broken = json.loads(json.dumps(one))
broken["primitives"][0]["state"]["semi_axes"] = [0.1, -1, "x"]
write("body", "bad_axes.json", json.dumps(broken))
write("body", "no_primitives.json", json.dumps({"format": "mimic-body", "name": "empty", "primitives": []}))

with open(os.path.join(CORPUS, "calibration", "six.json")) as f:
    cal = json.load(f)
write("calibration", "one_sensor.json", json.dumps(dict(cal, sensors=cal["sensors"][:1])))
write("calibration", "three_sensors.json", json.dumps(dict(cal, sensors=cal["sensors"][:3])))
no_sk = {k: v for k, v in cal.items() if k != "skeleton"}
write("calibration", "no_skeleton.json", json.dumps(no_sk))
bad = json.loads(json.dumps(cal))
bad["sensors"][0]["rotation_wxyz"] = [0, 0, 0, 0]
write("calibration", "zero_rotation.json", json.dumps(bad))
