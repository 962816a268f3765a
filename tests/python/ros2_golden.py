"""The ROS 2 wire format's expected values, from implementations that are not ours.

Prints one JSON object: the REP-2016 type hash (RIHS01) and the CDR bytes of
each message kind bycoms-ros2 speaks, from PyPI `rosbags` (its Jazzy type
store, `hash_rihs01`, `serialize_cdr`; services hashed from their
request, response and event types as rosidl builds them); the GID of rmw_zenoh liveliness
tokens, from PyPI `xxhash` (XXH3-128, laid out as rmw_zenoh lays it: the
128-bit value little-endian, low 64 bits first); the 33-byte attachment,
from eclipse-zenoh's own serializer (`zenoh.ext.z_serialize`, as rmw_zenoh's
zenoh-cpp `ext::Serializer` writes it).

protocol/ros2/tests/golden.rs pins this output and, in an `#[ignore]`d test
that `.ci/run` runs, compares it live. The fixed inputs below are the same
as that test's (`FIXED` there).
"""

import json
from pathlib import Path

import numpy

import xxhash
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_typestore, get_types_from_msg
from zenoh.ext import Int64, z_serialize

TS = get_typestore(Stores.ROS2_JAZZY)
# rosbags' Jazzy store has service_msgs/msg/ServiceEventInfo's client_gid as
# char[16]; rosidl maps .msg `char` to uint8, and only with uint8 does
# rmw_zenoh's documented AddTwoInts hash come out (SERVICES below).
_consts, _fields = TS.fielddefs["service_msgs/msg/ServiceEventInfo"]
TS.fielddefs["service_msgs/msg/ServiceEventInfo"] = (
    _consts,
    [
        (n, (Nodetype.ARRAY, ((Nodetype.BASE, ("uint8", 0)), 16))) if n == "client_gid" else (n, d)
        for n, d in _fields
    ],
)


def base(t):
    return (Nodetype.BASE, (t, 0))


def service(srv, request, response):
    """Registers a service's types under their srv names (rosbags' parser
    would rename them pkg/msg/…, and the name is part of the hash)."""
    nested = lambda t: (Nodetype.NAME, t)  # noqa: E731
    at_most_one = lambda t: (Nodetype.SEQUENCE, ((Nodetype.NAME, t), 1))  # noqa: E731
    TS.fielddefs[f"{srv}_Request"] = ([], request)
    TS.fielddefs[f"{srv}_Response"] = ([], response)
    TS.fielddefs[f"{srv}_Event"] = (
        [],
        [
            ("info", nested("service_msgs/msg/ServiceEventInfo")),
            ("request", at_most_one(f"{srv}_Request")),
            ("response", at_most_one(f"{srv}_Response")),
        ],
    )
    TS.fielddefs[srv] = (
        [],
        [
            ("request_message", nested(f"{srv}_Request")),
            ("response_message", nested(f"{srv}_Response")),
            ("event_message", nested(f"{srv}_Event")),
        ],
    )
    return TS.hash_rihs01(srv)


SERVICES = {
    "example_interfaces/srv/AddTwoInts": service(
        "example_interfaces/srv/AddTwoInts", [("a", base("int64")), ("b", base("int64"))], [("sum", base("int64"))]
    ),
    "std_srvs/srv/Trigger": service(
        "std_srvs/srv/Trigger", [], [("success", base("bool")), ("message", base("string"))]
    ),
}
# The Trigger messages' classes, for their CDR (the name is not on the wire).
TS.register(get_types_from_msg("", "std_srvs/msg/Trigger_Request"))
TS.register(get_types_from_msg("bool success\nstring message", "std_srvs/msg/Trigger_Response"))
T = TS.types

STAMP = T["builtin_interfaces/msg/Time"](sec=1_700_000_000, nanosec=123_456_789)


def header(frame):
    return T["std_msgs/msg/Header"](stamp=STAMP, frame_id=frame)


def pose(x, y, z, qz, qw):
    point = T["geometry_msgs/msg/Point"](x=x, y=y, z=z)
    quat = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=qz, w=qw)
    return T["geometry_msgs/msg/Pose"](position=point, orientation=quat)


def pose_stamped(x, y):
    return T["geometry_msgs/msg/PoseStamped"](
        header=header("world"), pose=pose(x, y, 0.0, 0.3826834323650898, 0.9238795325112867)
    )


def transform(child, x, y):
    v = T["geometry_msgs/msg/Vector3"](x=x, y=y, z=0.25)
    q = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=-0.5, w=0.8660254037844386)
    tf = T["geometry_msgs/msg/Transform"](translation=v, rotation=q)
    return T["geometry_msgs/msg/TransformStamped"](
        header=header("world"), child_frame_id=child, transform=tf
    )


def twist(lx, ly, lz, ax, ay, az):
    vector = T["geometry_msgs/msg/Vector3"]
    return T["geometry_msgs/msg/Twist"](linear=vector(x=lx, y=ly, z=lz), angular=vector(x=ax, y=ay, z=az))


MESSAGES = {
    "builtin_interfaces/msg/Time": STAMP,
    "std_msgs/msg/String": T["std_msgs/msg/String"](data="hello"),
    "std_msgs/msg/Header": header("robot_7"),
    "geometry_msgs/msg/Point": T["geometry_msgs/msg/Point"](x=1.5, y=-2.25, z=1e-3),
    "geometry_msgs/msg/Quaternion": T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
    "geometry_msgs/msg/Vector3": T["geometry_msgs/msg/Vector3"](x=-1.0, y=2.0, z=3.5),
    "geometry_msgs/msg/Pose": pose(1.5, -2.25, 0.0, 0.3826834323650898, 0.9238795325112867),
    "geometry_msgs/msg/PoseStamped": pose_stamped(1.5, -2.25),
    "geometry_msgs/msg/Transform": transform("robot1", 1.0, 2.0).transform,
    "geometry_msgs/msg/TransformStamped": transform("robot1", 1.0, 2.0),
    "tf2_msgs/msg/TFMessage": T["tf2_msgs/msg/TFMessage"](
        transforms=[transform("robot1", 1.0, 2.0), transform("robot12", -3.0, 0.5)]
    ),
    "nav_msgs/msg/Path": T["nav_msgs/msg/Path"](
        header=header("world"), poses=[pose_stamped(0.0, 0.0), pose_stamped(1.5, -2.25)]
    ),
    "rosgraph_msgs/msg/Clock": T["rosgraph_msgs/msg/Clock"](
        clock=T["builtin_interfaces/msg/Time"](sec=12, nanosec=500_000_000)
    ),
    "geometry_msgs/msg/Twist": twist(0.5, -0.125, 2.0, -1.0, 0.75, 3.25),
    "geometry_msgs/msg/TwistStamped": T["geometry_msgs/msg/TwistStamped"](
        header=header("base_link"), twist=twist(-0.25, 0.0, 0.0, 0.0, 0.0, 1.5)
    ),
}

COLOR = T["std_msgs/msg/ColorRGBA"](r=1.0, g=0.5, b=0.25, a=0.75)


def marker(ident, text):
    points = [T["geometry_msgs/msg/Point"](x=1.0, y=2.0, z=0.0), T["geometry_msgs/msg/Point"](x=-1.0, y=0.5, z=0.25)]
    empty_header = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id="")
    return T["visualization_msgs/msg/Marker"](
        header=header("world"), ns="beacons", id=ident, type=4, action=0,
        pose=pose(3.0, 4.0, 0.0, 0.3826834323650898, 0.9238795325112867),
        scale=T["geometry_msgs/msg/Vector3"](x=0.1, y=0.2, z=0.3), color=COLOR,
        lifetime=T["builtin_interfaces/msg/Duration"](sec=0, nanosec=0), frame_locked=False,
        points=points, colors=[], texture_resource="",
        texture=T["sensor_msgs/msg/CompressedImage"](header=empty_header, format="", data=numpy.zeros(0, numpy.uint8)),
        uv_coordinates=[], text=text, mesh_resource="",
        mesh_file=T["visualization_msgs/msg/MeshFile"](filename="", data=numpy.zeros(0, numpy.uint8)),
        mesh_use_embedded_materials=False,
    )


def diagnostic_status(level, name, message, hardware_id, values):
    kv = [T["diagnostic_msgs/msg/KeyValue"](key=k, value=v) for k, v in values]
    return T["diagnostic_msgs/msg/DiagnosticStatus"](
        level=level, name=name, message=message, hardware_id=hardware_id, values=kv
    )


STATUS = diagnostic_status(1, "bycoms/robot_3", "battery low", "cf3", [("battery_v", "3.4"), ("link", "ok")])

MESSAGES.update({
    "std_msgs/msg/ColorRGBA": COLOR,
    "visualization_msgs/msg/Marker": marker(7, "eps"),
    "visualization_msgs/msg/MarkerArray": T["visualization_msgs/msg/MarkerArray"](markers=[marker(7, "eps"), marker(2, "b")]),
    "nav_msgs/msg/OccupancyGrid": T["nav_msgs/msg/OccupancyGrid"](
        header=header("world"),
        info=T["nav_msgs/msg/MapMetaData"](
            map_load_time=T["builtin_interfaces/msg/Time"](sec=5, nanosec=6), resolution=0.5, width=3, height=2,
            origin=pose(-1.0, 2.0, 0.0, 0.3826834323650898, 0.9238795325112867),
        ),
        data=numpy.array([0, 100, -1, 0, 0, 100], numpy.int8),
    ),
    "diagnostic_msgs/msg/DiagnosticStatus": STATUS,
    "diagnostic_msgs/msg/DiagnosticArray": T["diagnostic_msgs/msg/DiagnosticArray"](
        header=header(""), status=[STATUS, diagnostic_status(3, "", "", "", [])]
    ),
})

# bycoms_msgs, read from the package's own .msg files (deploy/ros2/bycoms_msgs/msg).
BYCOMS_MSGS = Path(__file__).resolve().parents[2] / "deploy" / "ros2" / "bycoms_msgs" / "msg"
for _msg in sorted(BYCOMS_MSGS.glob("*.msg")):
    TS.register(get_types_from_msg(_msg.read_text(), f"bycoms_msgs/msg/{_msg.stem}"))

MESSAGES.update({
    "bycoms_msgs/msg/GateEvent": T["bycoms_msgs/msg/GateEvent"](
        stamp=T["builtin_interfaces/msg/Time"](sec=12, nanosec=300_000_000),
        robot=3, kind=1, arrived=True, x=44.5, y=-1.25, step=123,
    ),
    "bycoms_msgs/msg/RobotState": T["bycoms_msgs/msg/RobotState"](
        header=header("world"), robot=2, state=2, x=30.0, y=31.5, heading=-0.5, step=7, real=True,
    ),
})

# Tokens as rmw_zenoh's design document (docs/design) shows them.
TOKENS = [
    "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener",
    "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/"
    "std_msgs::msg::dds_::String_/"
    "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,7:,:,:,,",
]


def gid(token):
    return xxhash.xxh3_128_intdigest(token.encode()).to_bytes(16, "little")


# Each srv message: its srv name (hashed) and the class its CDR comes from.
SRV_MESSAGES = {
    "std_srvs/srv/Trigger_Request": (
        "std_srvs/msg/Trigger_Request",
        T["std_srvs/msg/Trigger_Request"](structure_needs_at_least_one_member=0),
    ),
    "std_srvs/srv/Trigger_Response": (
        "std_srvs/msg/Trigger_Response",
        T["std_srvs/msg/Trigger_Response"](success=True, message="stopped"),
    ),
}


def main():
    hashes = {name: TS.hash_rihs01(name) for name in [*MESSAGES, *SRV_MESSAGES]}
    cdr = {name: TS.serialize_cdr(msg, name).hex() for name, msg in MESSAGES.items()}
    cdr.update({name: TS.serialize_cdr(msg, as_msg).hex() for name, (as_msg, msg) in SRV_MESSAGES.items()})
    out = {
        "hashes": hashes,
        "cdr": cdr,
        "services": SERVICES,
        "gid": {token: gid(token).hex() for token in TOKENS},
        "attachment": z_serialize(
            (Int64(42), Int64(1_700_000_000_123_456_789), gid(TOKENS[1]))
        ).to_bytes().hex(),
    }
    print(json.dumps(out, indent=1, sort_keys=True))


def open_router(listen):
    """A zenoh router on `listen` (rmw_zenohd's place in a test), shared by
    the ROS 2 test clients."""
    import zenoh  # only the live clients need a session

    conf = zenoh.Config()
    conf.insert_json5("mode", '"router"')
    conf.insert_json5("listen/endpoints", json.dumps([listen]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    # No shared memory: the Python binding leaves its segment
    # (/dev/shm/<n>.zenoh) behind when the session closes, and a test must
    # leave nothing.
    conf.insert_json5("transport/shared_memory/enabled", "false")
    return zenoh.open(conf)


if __name__ == "__main__":
    main()
