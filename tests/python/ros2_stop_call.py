"""A ROS 2-over-zenoh client that is not ours calls a launch's stop service.

Plays the lab's router on argv[1]; finds the launch's `std_srvs/srv/Trigger`
service through its rmw_zenoh liveliness token (kind SS, as
`ros2 service list` does), checks the token's type hash against rosbags'
own, prints `found <service>`, and on the line `call` from stdin calls it
as an rmw_zenoh client does: the key expression built from the token, the
request in CDR by rosbags, the 33-byte attachment (sequence number 1,
timestamp, 0x10, the client's GID: PyPI xxhash's XXH3-128 of a client
token). It prints one JSON report of the reply: the response deserialized
by rosbags, whether its attachment carries our sequence number and GID.
Used by tests/tests/ros2_launch.rs.

usage: ros2_stop_call.py LISTEN_ENDPOINT DOMAIN_ID
"""

import json
import sys
import time

import xxhash
import zenoh

# The service's hash and the Trigger classes as rosbags builds them (the
# golden test's module: services hashed from their request, response and
# event types as rosidl does; rosbags' store has no srv types).
from ros2_golden import SERVICES, TS, open_router

TRIGGER = "std_srvs/srv/Trigger"
DDS = "std_srvs::srv::dds_::Trigger_"


def find_service(session, domain, deadline):
    """The first Trigger service token of the domain: (name, hash, token)."""
    while time.monotonic() < deadline:
        for reply in session.liveliness().get(f"@ros2_lv/{domain}/**", timeout=1.0):
            if reply.ok is None:
                continue
            token = str(reply.ok.key_expr)
            parts = token.split("/")
            if len(parts) >= 13 and parts[5] == "SS" and parts[10] == DDS:
                return parts[9].replace("%", "/"), parts[11], token
        time.sleep(0.1)
    raise SystemExit("no Trigger service token within the deadline")


def main():
    listen, domain = sys.argv[1], int(sys.argv[2])
    session = open_router(listen)
    print("ready", flush=True)
    name, type_hash, token = find_service(session, domain, time.monotonic() + 60)
    assert type_hash == SERVICES[TRIGGER], f"token hash {type_hash}"
    print(f"found {name}", flush=True)
    if sys.stdin.readline().strip() != "call":
        return
    key = f"{domain}/{name.strip('/')}/{DDS}/{type_hash}"
    request = TS.types["std_srvs/msg/Trigger_Request"](structure_needs_at_least_one_member=0)
    payload = bytes(TS.serialize_cdr(request, "std_srvs/msg/Trigger_Request"))
    client_token = f"@ros2_lv/{domain}/test/0/1/SC/%/%/caller/%emergency/{DDS}/{type_hash}/::,10:,:,:,,"
    gid = xxhash.xxh3_128_intdigest(client_token.encode()).to_bytes(16, "little")
    stamp = time.time_ns()
    attachment = (1).to_bytes(8, "little") + stamp.to_bytes(8, "little") + bytes([16]) + gid
    report = {"service": name, "token": token, "replies": 0}
    for reply in session.get(key, payload=payload, attachment=attachment, timeout=10.0):
        if reply.ok is None:
            report["error"] = reply.err.payload.to_bytes().decode(errors="replace")
            continue
        report["replies"] += 1
        response = TS.deserialize_cdr(reply.ok.payload.to_bytes(), "std_srvs/msg/Trigger_Response")
        report["success"] = bool(response.success)
        report["message"] = response.message
        got = reply.ok.attachment.to_bytes() if reply.ok.attachment is not None else b""
        report["attachment_len"] = len(got)
        report["same_sequence"] = got[:8] == (1).to_bytes(8, "little")
        report["same_gid"] = len(got) == 33 and got[16] == 16 and got[17:] == gid
        report["key"] = str(reply.ok.key_expr)
    report["expected_key"] = key
    print(json.dumps(report), flush=True)
    session.close()


if __name__ == "__main__":
    main()
