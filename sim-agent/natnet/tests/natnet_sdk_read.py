"""Reads the bycoms NatNet server with the NatNet SDK's own Python client.

Driven headlessly: the PyPI package `natnetsdk` (4.1.1) ships OptiTrack's
reference `NatNetClient` (threads, sockets, depacketizer). We configure it
for unicast on 127.0.0.1 with the server's command port, start it, ask for
the model definitions, and read back what *its* parser produced: the
rigid-body descriptions (names, ids) and the rigid bodies of every frame
(id, position, tracking-valid). Only hook: the client's own unpack methods
are wrapped to keep their results, since it only prints them.

Usage: natnet_sdk_read.py COMMAND_PORT SECONDS
Prints, after the client's own chatter has gone to stderr:
  name ID NAME
  body ID X Y Z VALID
  frames N
"""
import contextlib
import socket
import sys
import time

from natnetsdk.NatNetClient import NatNetClient


def main():
    port, seconds = int(sys.argv[1]), float(sys.argv[2])
    names, bodies, frames = {}, {}, [0]
    client = NatNetClient()
    client.set_server_address("127.0.0.1")
    client.set_client_address("127.0.0.1")
    client.set_use_multicast(False)
    client.command_port = port
    # No multicast group to join on loopback (the client skips it for this value).
    client.multicast_address = "255.255.255.255"
    client.set_print_level(0)

    unpack_descriptions = client._NatNetClient__unpack_data_descriptions
    unpack_frame = client._NatNetClient__unpack_mocap_data

    def descriptions(*args, **kwargs):
        offset, descs = unpack_descriptions(*args, **kwargs)
        for rb in descs.rigid_body_list:
            names[rb.id_num] = rb.sz_name.decode("utf-8")
        return offset, descs

    def frame(*args, **kwargs):
        offset, data = unpack_frame(*args, **kwargs)
        frames[0] += 1
        for rb in data.rigid_body_data.rigid_body_list:
            bodies[rb.id_num] = (rb.pos, rb.tracking_valid)
        return offset, data

    client._NatNetClient__unpack_data_descriptions = descriptions
    client._NatNetClient__unpack_mocap_data = frame

    with contextlib.redirect_stdout(sys.stderr):
        if not client.run():
            sys.exit("NatNetClient.run() failed")
        server = (client.server_ip_address, client.command_port)
        deadline = time.time() + seconds
        asked = 0.0
        while time.time() < deadline and not (names and frames[0] >= 10):
            if not names and time.time() - asked > 0.5:
                client.send_request(client.command_socket, client.NAT_REQUEST_MODELDEF, "", server)
                asked = time.time()
            time.sleep(0.05)
        # The unicast data socket has no timeout and closing it does not wake
        # a blocked recvfrom: raise the stop flag, then wake it with one
        # datagram, so the client's own shutdown() can join its threads.
        client.stop_threads = True
        wake = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        wake.sendto(b"\x0a\x00\x00\x00", ("127.0.0.1", client.data_socket.getsockname()[1]))
        wake.close()
        client.shutdown()

    print("app", client.get_application_name())
    print("version", ".".join(str(v) for v in client.get_nat_net_version_server()))
    for i, name in sorted(names.items()):
        print("name", i, name)
    for i, (pos, valid) in sorted(bodies.items()):
        print("body", i, pos[0], pos[1], pos[2], int(valid))
    print("frames", frames[0])


if __name__ == "__main__":
    main()
