#!/usr/bin/env python3
"""Watch a running BYCOMS swarm over zenoh: each robot's pose, its
controller mode and the deployment gate's events, one line each.

Why a separate Python client: a lab watches a run from a laptop that has
no Rust toolchain. This file needs only `pip install eclipse-zenoh==1.10.*`
and decodes the wire format documented in protocol/PROTOCOL.md by hand
(three readers: varint, little-endian f64, one byte), so it is also the
worked example of decoding BYCOMS messages in another language.

    python3 deploy/clients/watch.py --connect tcp/HOST:7447 --swarm NAME

HOST is an `orchestrator bridge` (or any zenoh router of the swarm).
Output lines (stdout):

    pose robot=1 step=120 x=12.500 y=3.250 heading=1.5708
    mode robot=1 mode=2 step=130
    gate robot=2 deployed x=15.500 y=15.500 step=400
    gate robot=1 stopped arrived=false x=... y=... step=...

Poses are printed every --pose-every steps per robot, modes when they
change, every gate event. Undecodable messages are reported on stderr
and skipped. Exit codes: 0 done (or --until-arrived satisfied), 1 cannot
connect, 2 --timeout passed first, 130 interrupted.
"""

import argparse
import json
import struct
import sys
import threading
import time

PROTOCOL_VERSION = 3
GATE_KINDS = {0: "deployed", 1: "stopped", 2: "died", 3: "timeout"}


class DecodeError(Exception):
    """A payload that is not a valid BYCOMS message."""


class Reader:
    """Postcard primitives over one payload (PROTOCOL.md section 4)."""

    def __init__(self, data):
        self.data = data
        self.at = 0

    def byte(self):
        if self.at >= len(self.data):
            raise DecodeError("truncated")
        b = self.data[self.at]
        self.at += 1
        return b

    def varint(self, max_bytes=10):
        value = 0
        for i in range(max_bytes):
            b = self.byte()
            value |= (b & 0x7F) << (7 * i)
            if b & 0x80 == 0:
                return value
        raise DecodeError("varint too long")

    def f64(self):
        if self.at + 8 > len(self.data):
            raise DecodeError("truncated")
        (v,) = struct.unpack_from("<d", self.data, self.at)
        self.at += 8
        return v

    def f32(self):
        if self.at + 4 > len(self.data):
            raise DecodeError("truncated")
        (v,) = struct.unpack_from("<f", self.data, self.at)
        self.at += 4
        return v

    def boolean(self):
        b = self.byte()
        if b > 1:
            raise DecodeError(f"bad bool {b}")
        return b == 1

    def finish(self):
        if self.at != len(self.data):
            raise DecodeError(f"{len(self.data) - self.at} trailing bytes")


def open_envelope(payload):
    r = Reader(payload)
    version = r.varint(3)
    if version != PROTOCOL_VERSION:
        raise DecodeError(f"protocol version {version}, this client speaks {PROTOCOL_VERSION}")
    return r


def pose_fields(r):
    return {
        "robot": r.varint(5),
        "x": r.f64(),
        "y": r.f64(),
        "heading": r.f64(),
        "step": r.varint(),
        "time_us": r.varint(),
    }


def decode_pose(payload):
    r = open_envelope(payload)
    pose = pose_fields(r)
    r.finish()
    return pose


def zigzag(n):
    """A zigzag varint's signed value (postcard's i64)."""
    return (n >> 1) ^ -(n & 1)


def decode_from_agent(payload):
    """FromAgent: only Status (index 2) matters to a watcher; the others are
    decoded so that malformed ones are still reported."""
    r = open_envelope(payload)
    variant = r.varint(5)
    robot = r.varint(5)
    if variant == 0:  # Register
        msg = {"kind": "register", "robot": robot, "agent": r.varint(5), "protocol_version": r.varint(3)}
        msg.update(instance=r.varint(), settings=r.varint(), failsafe_grace_ms=r.varint(5))
    elif variant == 1:  # Heartbeat
        msg = {"kind": "heartbeat", "robot": robot, "seq": r.varint()}
    elif variant == 2:  # Status
        msg = {"kind": "status", "robot": robot, "mode": r.byte(), "step": r.varint()}
    elif variant == 3:  # TickDone
        msg = {"kind": "tick_done", "robot": robot, "step": r.varint()}
    elif variant == 4:  # Telemetry (a real robot, from its gateway)
        msg = {"kind": "telemetry", "robot": robot, "period": r.varint(5), "state": r.varint(5), "mode": r.byte()}
        msg["mics"] = [r.f32() for _ in range(6)]
        msg["v_ave"] = r.f32()
        msg["gradient"] = r.f32() if r.boolean() else None
        msg.update(left=r.f32(), right=r.f32(), battery_mv=r.varint(3), health=r.byte(), robot_drops=r.varint(5))
    elif variant == 5:  # Link (a real robot's link, from its gateway)
        msg = {"kind": "link", "robot": robot, "up": r.boolean(), "silent_ms": r.varint(5), "refused": r.varint(5)}
    elif variant == 6:  # Failsafe (the agent's failsafe stopped its robot)
        msg = {"kind": "failsafe", "robot": robot, "silent_ms": r.varint(5)}
    elif variant == 7:  # Parked (lockstep: the robot will never move again)
        msg = {"kind": "parked", "robot": robot, "step": r.varint()}
    elif variant == 8:  # Clock (the agent's host clock against the orchestrator's)
        msg = {"kind": "clock", "robot": robot, "offset_us": zigzag(r.varint()), "round_trip_us": r.varint(5)}
    elif variant == 9:  # StopDone (the answer to Stop)
        msg = {"kind": "stop_done", "robot": robot, "on_link": r.boolean()}
    elif variant == 10:  # Commanded (a ROS 2 robot's velocity command, as published)
        msg = {"kind": "commanded", "robot": robot, "step": r.varint(), "linear": r.f64(), "angular": r.f64()}
        msg["sensed"] = None
        if r.boolean():
            intensity = r.f64()
            msg["sensed"] = {"intensity": intensity, "gradient": r.f64() if r.boolean() else None}
    else:
        raise DecodeError(f"unknown FromAgent variant {variant}")
    r.finish()
    return msg


def decode_gate(payload):
    r = open_envelope(payload)
    robot = r.varint(5)
    kind = r.varint(5)
    if kind not in GATE_KINDS:
        raise DecodeError(f"unknown GateKind {kind}")
    arrived = r.boolean() if kind == 1 else None
    event = {"robot": robot, "kind": GATE_KINDS[kind], "arrived": arrived, "x": r.f64(), "y": r.f64(), "step": r.varint()}
    r.finish()
    return event


def route(swarm, key):
    """Which topic of the swarm `key` is (PROTOCOL.md section 1)."""
    prefix = f"bycoms/{swarm}/"
    if not key.startswith(prefix):
        return None
    rest = key[len(prefix):].split("/")
    if rest == ["gate"]:
        return rest[0]
    if len(rest) == 3 and rest[0] == "robot" and rest[1].isdigit():
        return rest[2]
    return None


class Watcher:
    def __init__(self, args):
        self.args = args
        self.lock = threading.Lock()
        self.last_pose_step = {}
        self.last_mode = {}
        self.done = threading.Event()
        self.counts = {}

    def emit(self, line):
        print(line, flush=True)

    def on_sample(self, sample):
        key = str(sample.key_expr)
        payload = sample.payload.to_bytes()
        with self.lock:
            try:
                self.handle(key, payload)
            except DecodeError as e:
                print(f"error key={key} {e}", file=sys.stderr, flush=True)

    def handle(self, key, payload):
        topic = route(self.args.swarm, key)
        name = topic or "other"
        self.counts[name] = self.counts.get(name, 0) + 1
        if topic == "pose":
            p = decode_pose(payload)
            last = self.last_pose_step.get(p["robot"])
            if last is None or p["step"] - last >= self.args.pose_every:
                self.last_pose_step[p["robot"]] = p["step"]
                self.emit(
                    f"pose robot={p['robot']} step={p['step']} x={p['x']:.3f} y={p['y']:.3f} heading={p['heading']:.4f}"
                )
        elif topic == "from_agent":
            m = decode_from_agent(payload)
            if m["kind"] == "status" and self.last_mode.get(m["robot"]) != m["mode"]:
                self.last_mode[m["robot"]] = m["mode"]
                self.emit(f"mode robot={m['robot']} mode={m['mode']} step={m['step']}")
            elif m["kind"] == "link":
                self.emit(f"link robot={m['robot']} up={str(m['up']).lower()} silent_ms={m['silent_ms']}")
            elif m["kind"] == "failsafe":
                self.emit(f"failsafe robot={m['robot']} silent_ms={m['silent_ms']}")
        elif topic == "gate":
            e = decode_gate(payload)
            arrived = "" if e["arrived"] is None else f" arrived={str(e['arrived']).lower()}"
            self.emit(f"gate robot={e['robot']} {e['kind']}{arrived} x={e['x']:.3f} y={e['y']:.3f} step={e['step']}")
            if self.args.until_arrived and e["arrived"]:
                self.done.set()


def open_session(zenoh, endpoints, deadline):
    """A client session of the given routers; retried until `deadline` so the
    watcher may start before the bridge."""
    config = zenoh.Config()
    config.insert_json5("mode", '"client"')
    config.insert_json5("connect/endpoints", json.dumps(endpoints))
    config.insert_json5("scouting/multicast/enabled", "false")
    # No shared memory: the Python binding leaves its segment
    # (/dev/shm/<n>.zenoh) behind when the session closes.
    config.insert_json5("transport/shared_memory/enabled", "false")
    while True:
        try:
            return zenoh.open(config)
        except zenoh.ZError as e:
            if time.monotonic() >= deadline:
                raise SystemExit(f"cannot connect to {endpoints}: {e}")
            time.sleep(0.2)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--connect", action="append", required=True, metavar="ENDPOINT", help="e.g. tcp/10.0.0.5:7447")
    p.add_argument("--swarm", required=True, help="the launch's swarm name")
    p.add_argument("--pose-every", type=int, default=100, metavar="STEPS", help="print a robot's pose every STEPS steps")
    p.add_argument("--until-arrived", action="store_true", help="exit after a gate event with arrived=true")
    p.add_argument("--timeout", type=float, default=0.0, metavar="SECONDS", help="give up after SECONDS (0: never)")
    p.add_argument("--connect-timeout", type=float, default=10.0, metavar="SECONDS")
    args = p.parse_args()
    if args.pose_every < 1:
        p.error("--pose-every must be at least 1")

    import zenoh  # after argument parsing, so --help works without it

    session = open_session(zenoh, args.connect, time.monotonic() + args.connect_timeout)
    watcher = Watcher(args)
    sub = session.declare_subscriber(f"bycoms/{args.swarm}/**", watcher.on_sample)
    print(f"watching bycoms/{args.swarm}/** via {', '.join(args.connect)}", file=sys.stderr, flush=True)
    code = 0
    try:
        finished = watcher.done.wait(args.timeout if args.timeout > 0 else None)
        if not finished:
            print(f"timeout after {args.timeout} s", file=sys.stderr)
            code = 2
    except KeyboardInterrupt:
        code = 130
    sub.undeclare()
    session.close()
    with watcher.lock:
        print(f"messages per topic: {json.dumps(watcher.counts, sort_keys=True)}", file=sys.stderr, flush=True)
    return code


if __name__ == "__main__":
    sys.exit(main())
