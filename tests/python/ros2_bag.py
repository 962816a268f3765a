"""A ROS 2 bag written by `orchestrator record export --ros2`, read by readers that are not ours.

Reads the bag with PyPI `rosbags`' rosbag2 reader (every message
deserialized with the types its own `ros2msg` schemas define, and each
type's hash recomputed by rosbags from that schema and compared with the
channel's `topic_type_hash`), and again with PyPI `mcap-ros2-support`'s
decoder; counts the poses the launch core applied (`core/moved`, schema
`bycoms.Moved`: what the bag holds, not every pose motion capture
delivered) in the launch recording with PyPI `mcap`, and each robot's
`FromAgent::Commanded` reports there (a ROS 2 robot's commands: variant
index 10, the byte after the version). Prints one JSON report. Used by tests/tests/ros2_launch.rs.

usage: ros2_bag.py RECORDING.mcap BAG.mcap
"""

import json
import sys
from collections import Counter
from pathlib import Path

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore


def recording_poses(path):
    with open(path, "rb") as f:
        return sum(1 for schema, _, _ in make_reader(f).iter_messages() if schema and schema.name == "bycoms.Moved")


def recording_commanded(path):
    """Per robot, its agent's Commanded reports (`…/robot/<k>/from_agent`)."""
    counts = Counter()
    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            if schema and schema.name == "bycoms.FromAgent" and message.data[1:2] == b"\x0a":
                counts[channel.topic.split("/robot/")[1].split("/")[0]] += 1
    return counts


def with_rosbags(path):
    store = get_typestore(Stores.EMPTY)
    out = {"counts": Counter(), "undecoded": 0, "hash_mismatch": [], "path_poses": {}, "types": {}}
    with Reader(Path(path)) as reader:
        for c in reader.connections:
            store.register(get_types_from_msg(c.msgdef.data, c.msgtype))
        for c, _, raw in reader.messages():
            try:
                msg = store.deserialize_cdr(raw, c.msgtype)
            except Exception:  # noqa: BLE001 - any failure to decode counts
                out["undecoded"] += 1
                continue
            out["counts"][c.topic] += 1
            out["types"][c.topic] = c.msgtype
            if c.msgtype == "nav_msgs/msg/Path":
                out["path_poses"][c.topic] = len(msg.poses)
    return out, store


def with_mcap(path, store):
    out = {"counts": Counter(), "profile": None, "metadata": [], "hash_mismatch": [], "no_qos": []}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        out["profile"] = reader.get_header().profile
        for channel in reader.get_summary().channels.values():
            schema = reader.get_summary().schemas[channel.schema_id]
            if store.hash_rihs01(schema.name) != channel.metadata.get("topic_type_hash"):
                out["hash_mismatch"].append(channel.topic)
            if not channel.metadata.get("offered_qos_profiles", "").startswith("- history: "):
                out["no_qos"].append(channel.topic)
        for _, channel, _, _ in reader.iter_decoded_messages():
            out["counts"][channel.topic] += 1
        out["metadata"] = sorted((m.name, sorted(m.metadata)) for m in reader.iter_metadata())
    return out


def main():
    recording, bag = sys.argv[1], sys.argv[2]
    rosbags, store = with_rosbags(bag)
    mcap = with_mcap(bag, store)
    report = {"recording_poses": recording_poses(recording), "rosbags": rosbags, "mcap_ros2": mcap}
    report["recording_commanded"] = recording_commanded(recording)
    print(json.dumps(report))


if __name__ == "__main__":
    main()
