"""Software overhead per capture/pick/place cycle: one session, one CLI process per cycle, and the
bare ur_rtde calls a cycle cannot do without.

Runs the simulated controller (500 Hz, instant motion) on 127.0.0.250 with the demo cell plus a
place pose and no gripper (a gripper's settle time is a deliberate wait, not overhead), then:

- session: one ``handeye_pick.Cell``; each cycle is ``capture()`` where the arm stands and
  ``pick()`` of one candidate, which places the part;
- CLI: each cycle is one ``handeye-pick pick --capture-pose-ur ... --detection FILE`` process
  (start Python, connect, upload ur_rtde's script, pick, place, exit) with the same inputs;
- bare ur_rtde: the floor, what any program pays the controller for the same cycle with no check
  at all, straight from ur_rtde in this process: ``getTCPOffset``, ``getActualTCPPose``, two
  ``isPoseWithinSafetyLimits`` and two ``getInverseKinematicsHasSolution``, and the motion
  commands of the session's last cycle as the simulator recorded them, each as ur_rtde's
  synchronous ``moveL`` (a single move) or ``moveL(path)`` (a blended path, ``--blend-mm``).

Overhead of a cycle = its wall time minus the controller time spent moving during it, taken from
the simulated controller's motion record. Also prints where a session cycle's time goes per
controller call. Run: ``.venv/bin/python benchmarks/cycle.py [--cycles 50] [--blend-mm 20]``.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # mocks/ lives beside src/

from handeye_pick import Cell  # noqa: E402
from handeye_pick.cell.session import connect_ur_rtde  # noqa: E402
from handeye_pick.config.load import load_config  # noqa: E402
from handeye_pick.config.schema import CellConfig  # noqa: E402
from handeye_pick.detection import detection_from_point_mm  # noqa: E402
from handeye_pick.geometry import (  # noqa: E402
    invert,
    transform_point,
    ur_pose_to_matrix,
)
from handeye_pick.hand_eye.files import HandEyeMode, load_hand_eye  # noqa: E402
from handeye_pick.robot.port import RobotArm  # noqa: E402
from mocks.ur_controller import SimulatedController  # noqa: E402

HOST = "127.0.0.250"  # not 127.0.0.1: leaves the demo and the tests' addresses alone
TCP_OFFSET = (0.0, 0.0, 0.12, 0.0, 0.0, 0.0)
OBJECT_BASE_M = np.array([-0.52, -0.10, 0.06])  # where the part lies, base frame
CLI = [sys.executable, "-c", "import sys; from handeye_pick.cli import main; sys.exit(main())"]
CELL_YAML = f"""
robot:
  host: {HOST}
  tcp_offset: {list(TCP_OFFSET)}
  watchdog_s: 0.5  # the simulated controller can fall behind 0.2 s on a busy machine
hand_eye:
  mode: eye-in-hand
  file: {ROOT / "config" / "demo" / "hand_eye.yaml"}
  units: mm
grasp: {{approach_mm: 100, retreat_mm: 100}}
motion: {{speed_mps: 0.25, accel_mps2: 1.2, grasp_speed_mps: 0.05, blend_mm: 0}}
workspace: {{min_mm: [-800, -800, 20], max_mm: [800, 800, 700], max_tilt_deg: 30}}
audit: {{file: picks.jsonl}}
place:
  poses: [[-0.30, 0.35, 0.15, 3.14159265, 0, 0]]
  approach_mm: 80
  retreat_mm: 80
"""


class TimedArm:
    """Forwards every RobotArm call and adds its duration to ``seconds[name]``."""

    def __init__(self, arm: RobotArm, seconds: dict[str, list[float]]) -> None:
        self._arm = arm
        self._seconds = seconds

    def __getattr__(self, name: str) -> Any:
        call = getattr(self._arm, name)

        def timed(*args: Any, **kwargs: Any) -> Any:
            start = time.perf_counter()
            try:
                return call(*args, **kwargs)
            finally:
                self._seconds[name].append(time.perf_counter() - start)

        return timed


def _camera_point_mm(config: CellConfig, T_base_flange: np.ndarray) -> list[float]:
    """Where the camera at this flange pose sees the part (camera frame, mm)."""
    T_flange_cam = load_hand_eye(config.hand_eye.file, HandEyeMode.EYE_IN_HAND, "mm").T_cal
    p_cam = transform_point(invert(T_base_flange @ T_flange_cam), OBJECT_BASE_M)
    return [float(v) * 1000.0 for v in p_cam]


def _moving_s(ctl: SimulatedController, first_motion: int) -> tuple[float, int]:
    """Controller time spent moving by the motions after ``first_motion``, and the new count."""
    motions = ctl.motions
    return sum(m["moving_s"] for m in motions[first_motion:]), len(motions)


def _session(config: CellConfig, ctl: SimulatedController, cycles: int) -> tuple[
    list[float], dict[str, list[float]], list[dict[str, Any]]
]:
    """Overheads, seconds per arm call, and the motion commands of the last cycle as the
    simulated controller recorded them."""
    seconds: dict[str, list[float]] = defaultdict(list)

    def connect(cell_config: CellConfig) -> RobotArm:
        return TimedArm(connect_ur_rtde(cell_config), seconds)  # type: ignore[return-value]

    overheads = []
    with Cell(config, connect=connect) as cell:
        count = len(ctl.motions)
        for _ in range(cycles):
            first_command = len(ctl.commands)
            start = time.perf_counter()
            capture = cell.capture()
            assert capture.T_base_flange is not None
            point = _camera_point_mm(config, capture.T_base_flange)
            result = cell.pick([detection_from_point_mm(point, "benchmark")], capture)
            wall_s = time.perf_counter() - start
            if result.status != "placed":
                raise RuntimeError(f"cycle ended {result.status}")
            moving_s, count = _moving_s(ctl, count)
            overheads.append(wall_s - moving_s)
    motions = [c for c in ctl.commands[first_command:] if c["kind"] in ("moveL", "movePath")]
    return overheads, seconds, motions


def _bare_move(control: Any, command: dict[str, Any]) -> bool:
    """One recorded motion command again, synchronously: moveL, or moveL(path)."""
    if command["kind"] == "moveL":
        return bool(control.moveL(command["target"], command["speed"], command["accel"]))
    rows = [
        [*target, speed, accel, radius]
        for target, speed, accel, radius in zip(
            command["waypoints"], command["speeds"], command["accels"], command["radii"],
            strict=True,
        )
    ]
    return bool(control.moveL(rows))


def _bare(ctl: SimulatedController, cycles: int,
          motions: list[dict[str, Any]]) -> tuple[list[float], list[float]]:
    """Overheads, and the seconds of each synchronous motion command."""
    import rtde_control
    import rtde_receive

    receive = rtde_receive.RTDEReceiveInterface(HOST)
    control = rtde_control.RTDEControlInterface(HOST)
    targets = [c["target"] if c["kind"] == "moveL" else c["waypoints"][-1] for c in motions]
    overheads = []
    move_s = []
    count = len(ctl.motions)
    try:
        for _ in range(cycles):
            start = time.perf_counter()
            control.getTCPOffset()
            receive.getActualTCPPose()
            for pose in targets[:2]:
                control.isPoseWithinSafetyLimits(pose)
                control.getInverseKinematicsHasSolution(pose)
            for command in motions:
                move_start = time.perf_counter()
                if not _bare_move(control, command):
                    raise RuntimeError(f"bare {command['kind']} refused: {command}")
                move_s.append(time.perf_counter() - move_start)
            wall_s = time.perf_counter() - start
            moving_s, count = _moving_s(ctl, count)
            overheads.append(wall_s - moving_s)
    finally:
        control.stopScript()
        control.disconnect()
        receive.disconnect()
    return overheads, move_s


def _cli(config_path: Path, config: CellConfig, ctl: SimulatedController, cycles: int,
         folder: Path) -> list[float]:
    overheads = []
    count = len(ctl.motions)
    detection = folder / "detection.yaml"
    for _ in range(cycles):
        flange = ctl.snapshot().flange_pose  # the capture pose, latched outside the timing
        point = _camera_point_mm(config, ur_pose_to_matrix(flange))
        detection.write_text(f"position_mm: {point}\n")
        start = time.perf_counter()
        result = subprocess.run(
            [*CLI, "pick", "--config", str(config_path), "--detection", str(detection),
             "--capture-pose-ur", *(repr(float(v)) for v in flange), "--quiet"],
            capture_output=True, text=True, check=False,
        )
        wall_s = time.perf_counter() - start
        if result.returncode != 0:
            raise RuntimeError(f"CLI pick failed: {result.stderr}")
        moving_s, count = _moving_s(ctl, count)
        overheads.append(wall_s - moving_s)
    return overheads


def _stats(values: list[float]) -> tuple[float, float]:
    ms = sorted(v * 1000.0 for v in values)
    return statistics.median(ms), ms[min(len(ms) - 1, int(0.9 * len(ms)))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=50, help="cycles per variant (default 50)")
    parser.add_argument("--blend-mm", type=float, default=0.0,
                        help="motion.blend_mm of the cell (default 0: every target a stop)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp, SimulatedController(
        host=HOST, tcp_offset=TCP_OFFSET, instant=True
    ) as ctl:
        folder = Path(tmp)
        config_path = folder / "cell.yaml"
        config_path.write_text(CELL_YAML.replace("blend_mm: 0}", f"blend_mm: {args.blend_mm:g}}}"))
        config = load_config(config_path)
        session, seconds, motions = _session(config, ctl, args.cycles)
        cli = _cli(config_path, config, ctl, args.cycles, folder)
        bare, bare_move_s = _bare(ctl, args.cycles, motions)

    kinds = ", ".join(
        f"{c['kind']}" + (f" of {len(c['waypoints'])}" if c["kind"] == "movePath" else "")
        for c in motions
    )
    print(f"software overhead per capture/pick/place cycle ({args.cycles} cycles each, "
          f"simulated controller at {HOST}, 500 Hz, instant motion, blend_mm {args.blend_mm:g}: "
          f"{kinds})")
    rows: list[tuple[str, list[float]]] = [("one session (Cell)", session),
                                           ("one CLI pick process per cycle", cli),
                                           ("bare ur_rtde, no checks", bare)]
    for name, values in rows:
        median, p90 = _stats(values)
        print(f"  {name:<34} median {median:8.1f} ms   p90 {p90:8.1f} ms")
    ratio = statistics.median(cli) / statistics.median(session)
    print(f"  CLI per cycle / session: {ratio:.1f} x (median)")
    own = statistics.median(session) - statistics.median(bare)
    print(f"  session - bare ur_rtde: {own * 1000.0:+.1f} ms per cycle (median): what the "
          f"session's checks, watch, child process and audit cost beyond the controller calls")
    print(f"  session / bare ur_rtde: {statistics.median(session) / statistics.median(bare):.2f} x "
          "(median)")
    print(f"  bare synchronous motion command: median {statistics.median(bare_move_s) * 1000.0:.2f}"
          " ms (instant motion: the command's round trips and ur_rtde's wait for the end)")
    print("where a session cycle's time goes (per call, all cycles):")
    per_cycle: Callable[[list[float]], float] = lambda v: sum(v) * 1000.0 / args.cycles  # noqa: E731
    for name, values in sorted(seconds.items(), key=lambda item: -sum(item[1])):
        median = statistics.median(values) * 1000.0
        print(f"  {name:<32} {len(values) / args.cycles:5.1f} calls/cycle   median {median:6.2f}"
              f" ms   {per_cycle(values):7.1f} ms/cycle")


if __name__ == "__main__":
    main()
