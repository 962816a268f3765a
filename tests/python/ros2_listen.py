"""A ROS 2-over-zenoh listener that is not ours, for `launch --ros2`'s end-to-end test.

Plays the lab's router: opens a zenoh router listening on argv[1], finds
the launch's topics through their rmw_zenoh liveliness tokens (as
`ros2 topic list` does), subscribes to every sample of the domain, and
when a line arrives on stdin (the launch has ended) checks each sample
with its own means: the key expression built from rosbags' type hash and
rmw_zenoh's naming rule, the payload deserialized by rosbags, the
33-byte attachment parsed by hand, its GID against PyPI xxhash's XXH3-128
of the publisher's token, and the sequence numbers contiguous (none lost
once the route exists; the last is the count sent). It prints one JSON
report. Used by tests/tests/ros2_launch.rs.

Like a ROS 2 node that subscribes before the launch starts (RViz, a
recorder), it declares a node token and one subscription token per topic
it expects of a launch of ROBOTS robots, so the launch waits for the
route to it before its run, and no sample is lost at the start.

A ROS 2 ground robot's agent (`ros2-robot`) is checked by the same means:
its `cmd_vel` (Twist or TwistStamped) is one more publisher of the graph,
found by its token, its node named in the report (tests/tests/ros2_robot.rs).

usage: ros2_listen.py LISTEN_ENDPOINT DOMAIN_ID ROBOTS
"""

import json
import sys
import threading
from pathlib import Path

import xxhash
import zenoh
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from ros2_golden import open_router  # the one router of the ROS 2 test clients

TS = get_typestore(Stores.ROS2_JAZZY)
# bycoms_msgs, from the package's own .msg files, as a lab's colcon build reads them.
for _msg in sorted((Path(__file__).resolve().parents[2] / "deploy/ros2/bycoms_msgs/msg").glob("*.msg")):
    TS.register(get_types_from_msg(_msg.read_text(), f"bycoms_msgs/msg/{_msg.stem}"))


def dds_name(ros_type):
    pkg, kind, name = ros_type.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def parse_token(token):
    """A publisher token's (topic, DDS type, hash), or None."""
    parts = token.split("/")
    if len(parts) < 13 or parts[0] != "@ros2_lv" or parts[5] != "MP":
        return None
    return parts[9].replace("%", "/"), parts[10], parts[11]


# The topics a launch of n robots publishes, with their types.
SHARED_TOPICS = {
    "/clock": "rosgraph_msgs/msg/Clock",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/tf_static": "tf2_msgs/msg/TFMessage",
    "/map": "nav_msgs/msg/OccupancyGrid",
    "/beacons": "visualization_msgs/msg/MarkerArray",
    "/gate": "bycoms_msgs/msg/GateEvent",
}


def expected_topics(robots):
    topics = dict(SHARED_TOPICS)
    for k in range(1, robots + 1):
        topics[f"/robot_{k}/pose"] = "geometry_msgs/msg/PoseStamped"
        topics[f"/robot_{k}/path"] = "nav_msgs/msg/Path"
        topics[f"/robot_{k}/state"] = "bycoms_msgs/msg/RobotState"
    return topics


def subscription_tokens(zid, domain, robots):
    """A node's token and its subscriptions' (reliable, depth 10), as rmw_zenoh writes them."""
    node = f"@ros2_lv/{domain}/{zid}/0/0/NN/%/%/listener"
    tokens = [node]
    for eid, (topic, ros_type) in enumerate(sorted(expected_topics(robots).items()), start=1):
        tokens.append(
            f"@ros2_lv/{domain}/{zid}/0/{eid}/MS/%/%/listener/{topic.replace('/', '%')}/"
            f"{dds_name(ros_type)}/{TS.hash_rihs01(ros_type)}/::,10:,:,:,,"
        )
    return tokens


def check(samples, tokens, domain):
    """The report: what a ROS 2 subscriber would have seen."""
    publishers = {}
    for token in tokens:
        parsed = parse_token(token)
        if parsed:
            publishers[parsed[0]] = (token, parsed[1], parsed[2])
    by_key, by_node = {}, {}
    for topic, (token, dds, type_hash) in publishers.items():
        by_node[topic] = token.split("/")[8]
        ros_type = next(t for t in TS.types if t.count("/") == 2 and dds_name(t) == dds)
        assert TS.hash_rihs01(ros_type) == type_hash, f"{topic}: token hash {type_hash}"
        key = f"{domain}/{topic.strip('/')}/{dds}/{TS.hash_rihs01(ros_type)}"
        gid = xxhash.xxh3_128_intdigest(token.encode()).to_bytes(16, "little")
        by_key[key] = (topic, ros_type, gid)
    report = {"nodes": sorted(t for t in tokens if "/NN/" in t), "topics": {}, "unexpected": []}
    errors = {"undecoded": 0, "bad_attachment": 0, "bad_gid": 0}
    for key, payload, attachment in samples:
        if key not in by_key:
            report["unexpected"].append(key)
            continue
        topic, ros_type, gid = by_key[key]
        node = by_node[topic]
        entry = report["topics"].setdefault(topic, {"type": ros_type, "node": node, "seqs": [], "last": None})
        try:
            msg = TS.deserialize_cdr(payload, ros_type)
        except Exception:  # noqa: BLE001 - any failure to decode counts
            errors["undecoded"] += 1
            continue
        if len(attachment) != 33 or attachment[16] != 16:
            errors["bad_attachment"] += 1
            continue
        errors["bad_gid"] += attachment[17:] != gid
        entry["seqs"].append(int.from_bytes(attachment[:8], "little", signed=True))
        if ros_type == "geometry_msgs/msg/PoseStamped":
            entry["last"] = [msg.pose.position.x, msg.pose.position.y, msg.header.frame_id]
        elif ros_type == "nav_msgs/msg/Path":
            entry["last"] = len(msg.poses)
        elif ros_type == "visualization_msgs/msg/MarkerArray":
            entry["last"] = sorted({m.id for m in msg.markers})
        elif ros_type == "bycoms_msgs/msg/RobotState":
            entry["last"] = msg.state
        elif ros_type == "bycoms_msgs/msg/GateEvent":
            entry["last"] = (entry["last"] or 0) + 1
        elif ros_type == "nav_msgs/msg/OccupancyGrid":
            entry["last"] = [msg.info.width, msg.info.height, int((msg.data == 100).sum())]
        elif ros_type == "geometry_msgs/msg/Twist":
            entry["last"] = [msg.linear.x, msg.angular.z]
            entry["moving"] = entry.get("moving", 0) + (msg.linear.x != 0 or msg.angular.z != 0)
        elif ros_type == "geometry_msgs/msg/TwistStamped":
            entry["last"] = [msg.twist.linear.x, msg.twist.angular.z, msg.header.frame_id]
            entry["moving"] = entry.get("moving", 0) + (msg.twist.linear.x != 0 or msg.twist.angular.z != 0)
        elif ros_type == "rosgraph_msgs/msg/Clock":
            entry["last"] = msg.clock.sec * 1_000_000_000 + msg.clock.nanosec
    for entry in report["topics"].values():
        seqs = entry.pop("seqs")
        entry["count"] = len(seqs)
        entry["first_seq"] = seqs[0] if seqs else None
        entry["last_seq"] = seqs[-1] if seqs else None
        entry["contiguous"] = bool(seqs) and seqs == list(range(seqs[0], seqs[0] + len(seqs)))
    report.update(errors)
    return report


def main():
    listen, domain, robots = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    session = open_router(listen)
    declared = [
        session.liveliness().declare_token(t) for t in subscription_tokens(session.info.zid(), domain, robots)
    ]
    lock = threading.Lock()
    samples, tokens = [], set()

    def on_sample(s):
        attachment = s.attachment.to_bytes() if s.attachment is not None else b""
        with lock:
            samples.append((str(s.key_expr), s.payload.to_bytes(), attachment))

    def on_token(s):
        if s.kind == zenoh.SampleKind.PUT:
            with lock:
                tokens.add(str(s.key_expr))

    sub = session.declare_subscriber(f"{domain}/**", on_sample)
    graph = session.liveliness().declare_subscriber(f"@ros2_lv/{domain}/**", on_token)
    print("ready", flush=True)
    sys.stdin.readline()
    with lock:
        report = check(list(samples), set(tokens), domain)
    print(json.dumps(report), flush=True)
    for token in declared:
        token.undeclare()
    sub.undeclare()
    graph.undeclare()
    session.close()


if __name__ == "__main__":
    main()
