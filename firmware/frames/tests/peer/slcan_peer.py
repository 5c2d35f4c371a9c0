#!/usr/bin/env python3
"""SLCAN interoperability peer for mil-frames: python-can's slcan interface against a device
served by the Rust test on 127.0.0.1:PORT.

Usage: slcan_peer.py PORT REQUEST.json   (prints one JSON object on stdout)

Request: {"send": [{"id": 256, "extended": false, "remote": false, "dlc": 7, "data": "hex"}],
          "expect": 3}
It opens the bus at 1 Mbit/s (sleep_after_open=0), sends the frames, asks for the version and
the serial number, receives `expect` frames, shuts the bus down and prints
{"python_can": ..., "version": [hw, sw], "serial": "...", "received": [frames as above]}.
"""

import json
import sys

import can


def main():
    port = int(sys.argv[1])
    with open(sys.argv[2]) as f:
        request = json.load(f)
    bus = can.Bus(interface="slcan", channel=f"socket://127.0.0.1:{port}",
                  bitrate=1_000_000, sleep_after_open=0, timeout=0.01)
    try:
        for f in request["send"]:
            bus.send(can.Message(arbitration_id=f["id"], is_extended_id=f["extended"],
                                 is_remote_frame=f["remote"], dlc=f["dlc"],
                                 data=bytes.fromhex(f["data"])))
        hw, sw = bus.get_version(timeout=10)
        serial = bus.get_serial_number(timeout=10)
        received = []
        for _ in range(request["expect"]):
            m = bus.recv(timeout=10)
            if m is None:
                break
            received.append({"id": m.arbitration_id, "extended": m.is_extended_id,
                             "remote": m.is_remote_frame, "dlc": m.dlc,
                             "data": bytes(m.data or b"").hex()})
    finally:
        bus.shutdown()
    json.dump({"python_can": can.__version__, "version": [hw, sw], "serial": serial,
               "received": received}, sys.stdout)


if __name__ == "__main__":
    main()
