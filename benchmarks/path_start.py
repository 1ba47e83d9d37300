"""What a blended path costs to start, against the simulated controller, vs a single moveL.

ur_rtde's moveL(path) stops the control script (command 255), re-uploads the whole script with
the path injected on port 30003, polls until the program runs, then sends command 45. This
script times, through the real ur_rtde 1.6.5 client, the wall time from calling moveL(path,
async) to the first RTDE sample with the TCP moving, and the same for a single async moveL, for
each simulated program start time given (`--program-start-s`, the time the simulated controller
takes to start a received program; 0 is the simulator's default).

Run from the repository root: .venv/bin/python benchmarks/path_start.py [--runs 10]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import rtde_control
import rtde_receive

from mocks.ur_controller import SimulatedController

SPEED = 0.25  # m/s
ACCEL = 1.2  # m/s^2


def seconds_to_motion(r: rtde_receive.RTDEReceiveInterface, command: Callable[[], bool]) -> float:
    """Wall time from calling `command` to the first sample with the TCP moving."""
    started = time.perf_counter()
    if not command():
        raise RuntimeError("the move was refused")
    while max(abs(v) for v in r.getActualTCPSpeed()[:3]) == 0.0:
        time.sleep(0.0005)
    return time.perf_counter() - started


def measure(host: str, program_start_s: float, runs: int) -> tuple[list[float], list[float]]:
    """(path start times, single moveL start times) in s, `runs` of each, alternating."""
    paths: list[float] = []
    singles: list[float] = []
    with SimulatedController(host=host, speed_factor=4.0, program_start_s=program_start_s):
        c = rtde_control.RTDEControlInterface(host)
        r = rtde_receive.RTDEReceiveInterface(host)
        try:
            home = r.getActualTCPPose()
            out = [home[0] + 0.05, *home[1:]]
            corner = [home[0] + 0.05, home[1] + 0.05, *home[2:]]
            path = [[*out, SPEED, ACCEL, 0.01], [*corner, SPEED, ACCEL, 0.0]]
            for _ in range(runs):
                paths.append(seconds_to_motion(r, lambda: c.moveL(path, True)))
                while c.getAsyncOperationProgress() >= 0:
                    time.sleep(0.001)
                singles.append(seconds_to_motion(r, lambda: c.moveL(home, SPEED, ACCEL, True)))
                while c.getAsyncOperationProgress() >= 0:
                    time.sleep(0.001)
        finally:
            r.disconnect()
            c.disconnect()
    return paths, singles


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10, help="paths and single moves each")
    parser.add_argument("--host", default="127.0.0.202", help="loopback address to use")
    parser.add_argument("--program-start-s", type=float, nargs="+", default=[0.0, 0.3],
                        help="simulated program start times to measure with")
    args = parser.parse_args()
    for program_start_s in args.program_start_s:
        paths, singles = measure(args.host, program_start_s, args.runs)
        print(f"program start {program_start_s * 1000:.0f} ms: moveL(path) to motion "
              f"median {statistics.median(paths) * 1000:.1f} ms (min {min(paths) * 1000:.1f}, "
              f"max {max(paths) * 1000:.1f}); single moveL median "
              f"{statistics.median(singles) * 1000:.1f} ms (min {min(singles) * 1000:.1f}, "
              f"max {max(singles) * 1000:.1f}); {args.runs} runs each")
    return 0


if __name__ == "__main__":
    sys.exit(main())
