"""Inter-packet gap of the simulated controller's RTDE stream at 500 Hz while a client moves.

Starts a SimulatedController (real-time motion) on a loopback address, connects ur_rtde's control
and receive interfaces, subscribes a small raw RTDE reader to the 500 Hz stream and records the
arrival time of every data package while the control client runs moveL/moveJ back and forth.
Prints the gap median, p99 and max (ms). ur_rtde drops a stream after a 2.5 s gap.

Run from the repository root: .venv/bin/python benchmarks/stream_gap.py [--seconds 20]
"""

from __future__ import annotations

import argparse
import socket
import struct
import sys
import threading
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import rtde_control
import rtde_receive

from mocks.ur_controller import SimulatedController
from mocks.ur_controller.net import recv_exactly

HOME_Q = [0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0]
NAMES = "timestamp,actual_q,actual_TCP_pose,runtime_state,robot_status_bits,safety_status_bits,"


def _read_package(sock: socket.socket) -> tuple[int, bytes]:
    size, kind = struct.unpack(">HB", recv_exactly(sock, 3))
    return kind, recv_exactly(sock, size - 3)


def record_arrivals(host: str, stop: threading.Event, arrivals: list[float]) -> None:
    """Subscribe at 500 Hz and append the arrival time (s) of every data package."""
    with socket.create_connection((host, 30004)) as sock:
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        sock.sendall(struct.pack(">HBH", 5, ord("V"), 2))
        _read_package(sock)
        body = struct.pack(">d", 500.0) + NAMES.encode()
        sock.sendall(struct.pack(">HB", 3 + len(body), ord("O")) + body)
        _read_package(sock)
        sock.sendall(struct.pack(">HB", 3, ord("S")))
        _read_package(sock)
        while not stop.is_set():
            kind, _ = _read_package(sock)
            if kind == ord("U"):
                arrivals.append(time.perf_counter())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="measurement length")
    parser.add_argument("--host", default="127.0.0.201", help="loopback address to use")
    args = parser.parse_args()

    with SimulatedController(host=args.host, initial_q=HOME_Q) as ctl:
        # ur_rtde's constructors hold the GIL: build them before the reader thread starts.
        control = rtde_control.RTDEControlInterface(ctl.host)
        receive = rtde_receive.RTDEReceiveInterface(ctl.host)
        arrivals: list[float] = []
        stop = threading.Event()
        reader = threading.Thread(target=record_arrivals, args=(ctl.host, stop, arrivals))
        reader.start()
        start_pose = receive.getActualTCPPose()
        low = list(start_pose)
        low[2] -= 0.15
        moves = 0
        end = time.monotonic() + args.seconds
        while time.monotonic() < end:
            ok = control.moveL(low, 0.5, 2.0) and control.moveJ(HOME_Q, 1.5, 3.0)
            if not ok:
                print("a move failed", file=sys.stderr)
                break
            moves += 2
        stop.set()
        reader.join()
        control.disconnect()
        receive.disconnect()

    gaps_ms = np.diff(np.array(arrivals)) * 1e3
    print(f"stream gap at 500 Hz over {args.seconds:.0f} s, {len(arrivals)} packages, "
          f"{moves} moves (moveL 0.15 m / moveJ back):")
    print(f"  median {np.median(gaps_ms):.3f} ms, p99 {np.percentile(gaps_ms, 99):.3f} ms, "
          f"max {np.max(gaps_ms):.3f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
