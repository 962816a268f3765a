"""A ROS 2 motion-capture driver that is not ours, for the ROS 2 mocap end-to-end test.

Plays the lab's side of a launch with `mocap.source = "ros2"`: the lab's
router (rmw_zenohd's place: a zenoh router listening on ROUTER) and a
driver node on it, which reads the emulated lab's OptiTrack with
OptiTrack's own Python NatNet client (PyPI natnetsdk) and publishes each
tracked rigid body as a geometry_msgs/msg/PoseStamped, the way vrpn_mocap
does: one topic per body, Z up (REP-103: Motive's Y-up frame turned, as a
driver configured for ROS does), metres, frame `world`, stamped with the
mocap system's own frame time. Every byte is made here, with its own
means: the CDR by rosbags' serializer, the type hash by rosbags'
hash_rihs01, the key expression and the liveliness tokens (node NN,
publishers MP) by rmw_zenoh's naming rule written out below, the GID by
PyPI xxhash's XXH3-128 of the token, the 33-byte attachment packed by hand.

usage: ros2_mocap_driver.py NATNET_COMMAND_PORT ROUTER DOMAIN ID=TOPIC...
Prints `ready` once the router listens, the tokens are declared and the
NatNet client runs; on a line on stdin (or its end), one JSON report:
{"frames": N, "published": {TOPIC: COUNT}, "subscriptions": [[NODE,
TOPIC, DDS TYPE, HASH], ...], "type_hash": rosbags' PoseStamped hash}: the subscription tokens (MS) of the graph,
read as `ros2 topic info` reads them (what subscribes to what).
"""

import json
import os
import struct
import sys
import threading
import time

import xxhash
import zenoh
from natnetsdk.NatNetClient import NatNetClient
from rosbags.typesys import Stores, get_typestore
from ros2_golden import open_router  # the one router of the ROS 2 test clients

TS = get_typestore(Stores.ROS2_JAZZY)
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
T = TS.types
# rmw_zenoh's compact QoS of a best-effort, keep-last-1 publisher
# (`qos_to_keyexpr`: only what differs from its default is written).
QOS = "2::,1:,:,:,,"


def dds_name(ros_type):
    pkg, kind, name = ros_type.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


class Publisher:
    """One rmw_zenoh publisher: its key, token, GID and sequence numbers."""

    def __init__(self, session, domain, zid, node, eid, topic):
        type_hash = TS.hash_rihs01(POSE_STAMPED)
        mangled = topic.replace("/", "%")
        self.token = (
            f"@ros2_lv/{domain}/{zid}/0/{eid}/MP/%/%/{node}/{mangled}/{dds_name(POSE_STAMPED)}/{type_hash}/{QOS}"
        )
        self.key = f"{domain}/{topic.strip('/')}/{dds_name(POSE_STAMPED)}/{type_hash}"
        self.gid = xxhash.xxh3_128_intdigest(self.token.encode()).to_bytes(16, "little")
        self.held = session.liveliness().declare_token(self.token)
        self.publisher = session.declare_publisher(self.key)
        self.seq = 0

    def put(self, payload):
        self.seq += 1
        attachment = struct.pack("<qq", self.seq, time.time_ns()) + bytes([16]) + self.gid
        self.publisher.put(payload, attachment=attachment)


def pose_stamped(stamp_s, pos, rot):
    """Motive's Y-up pose as ROS's Z-up one: (x, y, z) = (X, -Z, Y), the
    quaternion's vector part turned alike (a rotation of +90 deg about X)."""
    x, y, z = pos
    qx, qy, qz, qw = rot
    sec = int(stamp_s)
    stamp = T["builtin_interfaces/msg/Time"](sec=sec, nanosec=int(round((stamp_s - sec) * 1e9)) % 1_000_000_000)
    header = T["std_msgs/msg/Header"](stamp=stamp, frame_id="world")
    point = T["geometry_msgs/msg/Point"](x=float(x), y=float(-z), z=float(y))
    quat = T["geometry_msgs/msg/Quaternion"](x=float(qx), y=float(-qz), z=float(qy), w=float(qw))
    pose = T["geometry_msgs/msg/Pose"](position=point, orientation=quat)
    return T[POSE_STAMPED](header=header, pose=pose)


def natnet_client(port, on_frame):
    """OptiTrack's client on loopback, its frame parser wrapped to hand
    every parsed frame to `on_frame` (it only prints them otherwise)."""
    client = NatNetClient()
    client.set_server_address("127.0.0.1")
    client.set_client_address("127.0.0.1")
    client.set_use_multicast(False)
    client.command_port = port
    client.multicast_address = "255.255.255.255"
    client.set_print_level(0)
    unpack_frame = client._NatNetClient__unpack_mocap_data

    def frame(*args, **kwargs):
        offset, data = unpack_frame(*args, **kwargs)
        on_frame(data)
        return offset, data

    client._NatNetClient__unpack_mocap_data = frame
    return client


def main():
    # The SDK prints from its own threads: all of it to stderr, our lines
    # alone on stdout.
    out, sys.stdout = sys.stdout, sys.stderr
    port, router, domain = int(sys.argv[1]), sys.argv[2], int(sys.argv[3])
    topics = {int(k): v for k, v in (a.split("=", 1) for a in sys.argv[4:])}
    session = open_router(router)
    zid = str(session.info.zid())
    node = "mocap_driver"
    node_token = session.liveliness().declare_token(f"@ros2_lv/{domain}/{zid}/0/0/NN/%/%/{node}")
    publishers = {k: Publisher(session, domain, zid, node, 10 + k, t) for k, t in topics.items()}
    lock, frames, subscriptions = threading.Lock(), [0], set()

    def on_token(sample):
        parts = str(sample.key_expr).split("/")
        if sample.kind == zenoh.SampleKind.PUT and len(parts) >= 13 and parts[5] == "MS":
            with lock:
                subscriptions.add((parts[8], parts[9].replace("%", "/"), parts[10], parts[11]))

    graph = session.liveliness().declare_subscriber(f"@ros2_lv/{domain}/**", on_token)

    def on_frame(data):
        with lock:
            frames[0] += 1
            stamp = data.suffix_data.timestamp
            for rb in data.rigid_body_data.rigid_body_list:
                if rb.tracking_valid and rb.id_num in publishers:
                    msg = pose_stamped(stamp, rb.pos, rb.rot)
                    publishers[rb.id_num].put(bytes(TS.serialize_cdr(msg, POSE_STAMPED)))

    client = natnet_client(port, on_frame)
    if not client.run():
        sys.exit("NatNetClient.run() failed")
    print("ready", file=out, flush=True)
    sys.stdin.readline()
    with lock:
        report = {
            "frames": frames[0],
            "published": {topics[k]: p.seq for k, p in publishers.items()},
            "subscriptions": sorted(subscriptions),
            "type_hash": TS.hash_rihs01(POSE_STAMPED),
        }
    print(json.dumps(report), file=out, flush=True)
    del node_token, graph
    # The SDK's unicast data thread blocks in recvfrom for ever: end here.
    os._exit(0)


if __name__ == "__main__":
    main()
