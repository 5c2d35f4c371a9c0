#!/usr/bin/env python3
"""Smoke test of the QEMU build of mil-firmware over SLCAN (raw TCP socket, no packages).

Starts QEMU's netduinoplus2 with the firmware's USART1 on a TCP port, then plays the servo
controller and a host tool:

1. handshake: `V` repeated until the version line comes back (bytes sent before the
   firmware enables its USART are lost), then `O`;
2. Start command, then SAMPLES measurements in lockstep (one measurement line, wait for its
   demand line), checking every demand (counter echo, finite, inside the limits);
3. malformed frames (wrong length, "not available" position, free ID in the MiL range) and a
   foreign frame: no answer, counted;
4. commands: a NaN value (refused by the decoder, result 11), an out-of-range safe demand
   (result 130), a valid tyre damping without the calibration unlocked (result 147, locked);
5. measurements stop: the watchdog's tick must trip COMM_TIMEOUT (fault bit 4) and send
   demand frames by itself that ramp to the safe demand;
6. ClearFault, then `C`: the firmware prints its report on semihosting and exits 0.

Usage: smoke.py [ELF] [--build] [--samples N] [--icount SHIFT|none] [--port P]
Default ELF: $CARGO_TARGET_DIR (else <workspace>/target)/thumbv7em-none-eabihf/release/
mil-firmware, which must be the QEMU build; `--build` runs
`cargo build -p mil-firmware --target thumbv7em-none-eabihf --release --features qemu` first.
Exit status 0 when every check passed.
"""

import argparse
import math
import os
import socket
import struct
import subprocess
import sys
import time

BASE = 0x100
MEASUREMENT = BASE + 0x00
AUX = BASE + 0x08
DEMAND = BASE + 0x10
STATUS = BASE + 0x20
COMMAND = BASE + 0x21
ACK = BASE + 0x22

SAFE_DEMAND = 1667.7
LIMIT_MIN, LIMIT_MAX = -1000.0, 12000.0
COMM_TIMEOUT = 1 << 4


def line(can_id, data):
    return b"t%03X%d%s\r" % (can_id, len(data), data.hex().upper().encode())


def measurement(position_m, road_m, counter):
    pos = round(position_m * 1e6) & 0xFFFFFF
    road = round(road_m * 1e6) & 0xFFFFFF
    word = pos | (road << 24) | ((counter & 0xFF) << 48)
    return line(MEASUREMENT, word.to_bytes(7, "little"))


def command(cmd, index, value_bits):
    return line(COMMAND, bytes([cmd, index, 0, 0]) + struct.pack("<I", value_bits))


def f32_bits(v):
    return struct.unpack("<I", struct.pack("<f", v))[0]


def parse(text):
    """A `t` line (without `\\r`) as (id, bytes), else None."""
    if not text.startswith(b"t") or len(text) < 5:
        return None
    can_id = int(text[1:4], 16)
    n = int(text[4:5])
    return can_id, bytes.fromhex(text[5 : 5 + 2 * n].decode())


def demand(data):
    word = int.from_bytes(data, "little")
    raw = word & 0xFFFFFFFF
    if raw >= 1 << 31:
        raw -= 1 << 32
    return {
        "demand": raw * 0.1,
        "counter": (word >> 32) & 0xFF,
        "mode": (word >> 40) & 3,
        "fault": (word >> 42) & 1,
    }


def status(data):
    mode, fault, missed, late, malformed = struct.unpack("<BBHHH", data)
    return dict(mode=mode, fault=fault, missed=missed, late=late, malformed=malformed)


class Link:
    def __init__(self, sock):
        self.sock = sock
        self.buf = b""
        self.statuses = []

    def send(self, data):
        self.sock.sendall(data)

    def read_line(self, timeout):
        """Next reply: a line ending in `\\r` (without it) or BEL; None on timeout."""
        deadline = time.monotonic() + timeout
        while True:
            for i, b in enumerate(self.buf):
                if b in (0x0D, 0x07):
                    out, self.buf = self.buf[: i + (b == 0x07)], self.buf[i + 1 :]
                    return out
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            self.sock.settimeout(left)
            try:
                chunk = self.sock.recv(4096)
            except socket.timeout:
                return None
            if not chunk:
                raise EOFError("QEMU closed the connection")
            self.buf += chunk

    def frame(self, wanted_id, timeout=5.0):
        """Reads until a frame with `wanted_id`; keeps status frames."""
        deadline = time.monotonic() + timeout
        while True:
            text = self.read_line(max(0.0, deadline - time.monotonic()))
            if text is None:
                return None
            f = parse(text)
            if f is None:
                continue
            if f[0] == STATUS:
                self.statuses.append(status(f[1]))
            if f[0] == wanted_id:
                return f[1]


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what, flush=True)
    if not cond:
        raise SystemExit(1)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.abspath(os.path.join(here, "..", "..", ".."))
    ap = argparse.ArgumentParser()
    target_dir = os.environ.get("CARGO_TARGET_DIR") or os.path.join(root, "target")
    if not os.path.isabs(target_dir):
        target_dir = os.path.join(root, target_dir)
    ap.add_argument(
        "elf",
        nargs="?",
        default=os.path.join(target_dir, "thumbv7em-none-eabihf/release/mil-firmware"),
    )
    ap.add_argument("--build", action="store_true", help="build the QEMU firmware first")
    ap.add_argument("--samples", type=int, default=3000)
    ap.add_argument("--icount", default="3", help="QEMU -icount shift, or 'none'")
    ap.add_argument("--port", type=int, default=0)
    ap.add_argument("--timeout", type=int, default=600)
    args = ap.parse_args()
    if args.build:
        subprocess.run(
            ["cargo", "build", "-p", "mil-firmware", "--target", "thumbv7em-none-eabihf",
             "--release", "--features", "qemu"],
            cwd=root, check=True,
        )

    # With port 0 QEMU listens on a port the kernel picks and names it on stderr (binding
    # port 0 here and handing the port to QEMU races with other processes starting).
    port = args.port
    cmd = [
        "timeout", "--kill-after=10", str(args.timeout),
        "qemu-system-arm", "-machine", "netduinoplus2", "-nographic",
        "-monitor", "none", "-semihosting-config", "enable=on,target=native",
        "-serial", f"tcp:127.0.0.1:{port},server=on,wait=on,nodelay=on",
    ]
    if args.icount != "none":
        cmd += ["-icount", f"shift={args.icount},align=off"]
    cmd += ["-kernel", args.elf]
    print(" ".join(cmd), flush=True)
    qemu = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    early_stderr = b""
    if port == 0:
        mark = b"waiting for connection on: disconnected:tcp:127.0.0.1:"
        line = qemu.stderr.readline()
        early_stderr += line
        check(mark in line, f"QEMU names its port: {line!r}")
        port = int(line.split(mark, 1)[1].split(b",", 1)[0])
    sock = None
    for _ in range(200):
        try:
            sock = socket.create_connection(("127.0.0.1", port), timeout=1)
            break
        except OSError:
            time.sleep(0.05)
    check(sock is not None, f"connected to QEMU on port {port}")
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    link = Link(sock)
    try:
        run(link, args.samples)
    finally:
        sock.close()
    try:
        out, err = qemu.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        qemu.kill()
        out, err = qemu.communicate()
    sys.stdout.write(out.decode(errors="replace"))
    sys.stderr.write((early_stderr + err).decode(errors="replace"))
    check(qemu.returncode == 0, f"firmware exited with status {qemu.returncode}")
    report = out.decode(errors="replace")
    check("mil-firmware report:" in report, "final report printed")
    print("smoke test passed")


def run(link, samples):
    # 1. Handshake: repeat `V` until answered.
    t_start = time.monotonic()
    answered = False
    while time.monotonic() - t_start < 30:
        link.send(b"V\r")
        reply = link.read_line(0.2)
        if reply is not None and reply.startswith(b"V"):
            answered = True
            break
    check(answered, f"SLCAN handshake answered after {time.monotonic() - t_start:.2f} s")
    while link.read_line(0.3) is not None:  # drain answers to repeated V
        pass
    link.send(b"O\r")
    check(link.read_line(2.0) == b"", "O answered with OK")

    # 2. Start, then lockstep.
    link.send(command(1, 0, 0))
    ack = link.frame(ACK)
    check(ack is not None and ack[2] == 0 and ack[3] == 1, f"Start acknowledged: {ack and ack.hex()}")
    t0 = time.monotonic()
    worst = 0.0
    for k in range(samples):
        road = 0.005 * math.sin(2 * math.pi * 2.0 * k / 2000.0)
        link.send(measurement(0.0, road, k))
        data = link.frame(DEMAND)
        if data is None:
            check(False, f"demand for sample {k}")
        d = demand(data)
        if d["counter"] != k % 256 or d["mode"] != 1 or not (LIMIT_MIN <= d["demand"] <= LIMIT_MAX):
            check(False, f"demand {k}: {d}")
        # The tyre force: static load + k_t (z - x) + c_t d/dt(z - x), x = 0.
        expected = SAFE_DEMAND + 2.5e5 * road
        worst = max(worst, abs(d["demand"] - expected))
    dt = time.monotonic() - t0
    check(True, f"{samples} samples in lockstep, {samples / dt:.0f} samples/s; largest |demand - k_t z - F0| {worst:.1f} N (damping term)")
    # The status frame of a step follows its demand: the last one may still be unread.
    n = len(link.statuses)
    check(n in (samples // 200 - 1, samples // 200), f"{n} status frames (one every 200 steps)")
    last = link.statuses[-1]
    check(last["mode"] == 1 and last["fault"] == 0 and last["missed"] == 0, f"status: {last}")

    # 3. Malformed and foreign frames: no answer.
    link.send(line(MEASUREMENT, bytes(6)))                            # wrong length
    link.send(line(MEASUREMENT, bytes([0, 0, 0x80, 0, 0, 0, 0])))     # position not available
    link.send(line(BASE + 0x18, bytes(2)))                            # free ID in the range
    link.send(line(0x050, bytes(3)))                                  # foreign
    # A jump of 3 in the counter: 2 missed.
    link.send(measurement(0.0, 0.0, samples + 2))
    d = link.frame(DEMAND)
    check(d is not None and demand(d)["counter"] == (samples + 2) % 256, "measurement after the junk answered")

    # 4. Commands.
    link.send(command(4, 1, f32_bits(float("nan"))))
    ack = link.frame(ACK)
    check(ack is not None and ack[2] == 11, f"NaN parameter value refused with code 11: {ack and ack.hex()}")
    link.send(command(4, 8, f32_bits(1.0e5)))
    ack = link.frame(ACK)
    check(ack is not None and ack[2] == 130, f"safe demand beyond the limits refused with code 130: {ack and ack.hex()}")
    # A valid tyre damping without the calibration unlocked (no XCP session): refused, 147.
    link.send(command(4, 1, f32_bits(600.0)))
    ack = link.frame(ACK)
    check(ack is not None and ack[2] == 147 and ack[3] == 1, f"tyre damping 600 N s/m refused as locked (147): {ack and ack.hex()}")
    # Drive the demand up (road +20 mm: about 6.7 kN) so the ramp to safe is visible.
    for k in range(samples + 3, samples + 3 + 40):
        link.send(measurement(0.0, 0.02, k))
        if link.frame(DEMAND) is None:
            check(False, f"demand for sample {k}")
    # Run to the next status frame to read the counters.
    n_status = len(link.statuses)
    k = samples + 3 + 40
    while len(link.statuses) == n_status:
        link.send(measurement(0.0, 0.02, k))
        link.frame(DEMAND)
        k += 1
    st = link.statuses[-1]
    # Malformed: the three junk frames and the NaN command (it failed to decode too).
    check(st["malformed"] == 4 and st["missed"] == 2, f"malformed 4 and missed 2 counted: {st}")

    # 5. Silence: the watchdog trips and ramps the demand to safe by itself.
    t_quiet = time.monotonic()
    first = link.frame(DEMAND, timeout=30.0)
    check(first is not None, f"unsolicited demand after {time.monotonic() - t_quiet:.2f} s of silence")
    d = demand(first)
    check(d["mode"] == 2 and d["fault"] == 1, f"watchdog tripped: mode Fault, fault flag set: {d}")
    ramp = [d["demand"]]
    while len(ramp) < 30:
        data = link.frame(DEMAND, timeout=10.0)
        check(data is not None, "tick demand")
        ramp.append(demand(data)["demand"])
    steps = [a - b for a, b in zip(ramp, ramp[1:])]
    check(all(abs(s - 25.0) < 0.2 for s in steps), f"ramp 25 N per tick (5e4 N/s x 0.5 ms): {ramp[0]:.1f} -> {ramp[-1]:.1f} N")
    period = (time.monotonic() - t_quiet) / len(ramp)
    print(f"     tick period seen from the host: {period * 1000:.0f} ms", flush=True)
    # A status frame shows COMM_TIMEOUT (one per 200 ticks: set K = 5 to see one soon).
    link.send(command(4, 0, f32_bits(5.0)))  # parameter 0: the status period
    check(link.frame(ACK) is not None, "status period K = 5 acknowledged")
    n_status = len(link.statuses)
    while len(link.statuses) == n_status:
        check(link.frame(DEMAND, timeout=10.0) is not None, "tick demand")
    st = link.statuses[-1]
    check(st["mode"] == 2 and st["fault"] & COMM_TIMEOUT, f"status reports COMM_TIMEOUT: {st}")

    # 6. Clear the fault, close: report and exit 0.
    link.send(command(3, 0, 0))
    ack = link.frame(ACK)
    check(ack is not None and ack[2] == 0 and ack[3] == 0, f"ClearFault acknowledged, Idle: {ack and ack.hex()}")
    link.send(b"C\r")


if __name__ == "__main__":
    main()
