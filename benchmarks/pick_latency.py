"""Pick latency against the simulated controller (500 Hz RTDE, instant motion).

Prints, as median and 90th percentile over repeated runs:

- detection in hand -> first moveL sent, with a connected session (everything the pick does
  before moving: readiness check, fresh flange pose, chain, pre-flight checks with the
  controller's own limit and IK queries, plan record fsync'd to the audit file);
- the compute part alone (hand-eye chain, grasp targets, workspace and tilt checks);
- where the connected-session time goes, per controller call;
- one pipe round trip to the ur_rtde child process (no controller involved);
- a new connection (connect + close), for contrast.

Run from the repository root: ``python benchmarks/pick_latency.py [--runs N]``.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import statistics
import sys
import tempfile
import time
from collections import defaultdict
from collections.abc import Callable, Mapping
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # mocks/ lives beside src/, not in the installed package

from handeye_pick.audit import AuditLog  # noqa: E402
from handeye_pick.calibration import load_hand_eye  # noqa: E402
from handeye_pick.config import AuditConfig, CellConfig, load_config  # noqa: E402
from handeye_pick.detection import load_detection  # noqa: E402
from handeye_pick.geometry import Transform  # noqa: E402
from handeye_pick.grasp import plan_targets  # noqa: E402
from handeye_pick.pick import run_pick  # noqa: E402
from handeye_pick.progress import Progress  # noqa: E402
from handeye_pick.robot.port import OutputBank, ProgressCallback, RobotStatus  # noqa: E402
from handeye_pick.robot.ur_rtde_arm import URRtdeArm  # noqa: E402
from handeye_pick.safety import tilt_deg, workspace_problem  # noqa: E402
from mocks.ur_controller import SimulatedController  # noqa: E402

HOST = "127.0.0.250"  # not 127.0.0.1: leaves the demo and the tests' addresses alone
CONFIG = ROOT / "config" / "demo.yaml"
DETECTION = ROOT / "config" / "demo" / "detection.yaml"


class FirstMoveReached(Exception):
    """Raised by TimedArm at the first moveL, after it was sent: the measurement is done."""


class TimedArm:
    """A RobotArm that times every call of the arm it wraps and notes when moveL is sent."""

    def __init__(self, arm: URRtdeArm) -> None:
        self.arm = arm
        self.seconds: dict[str, list[float]] = defaultdict(list)
        self.first_move_s: float | None = None

    def _timed(self, name: str, call: Callable[[], object]) -> object:
        start = time.perf_counter()
        try:
            return call()
        finally:
            self.seconds[name].append(time.perf_counter() - start)

    def status(self) -> RobotStatus:
        return self._timed("status (RTDE + dashboard)", self.arm.status)  # type: ignore[return-value]

    def tcp_offset(self) -> Transform:
        return self._timed("tcp_offset (getTCPOffset)", self.arm.tcp_offset)  # type: ignore[return-value]

    def tcp_pose(self) -> Transform:
        return self._timed("tcp_pose", self.arm.tcp_pose)  # type: ignore[return-value]

    def flange_pose(self) -> Transform:
        return self._timed("flange_pose (fresh sample)", self.arm.flange_pose)  # type: ignore[return-value]

    def is_pose_within_safety_limits(self, T_base_tcp: Transform) -> bool:
        return bool(
            self._timed(
                "isPoseWithinSafetyLimits",
                lambda: self.arm.is_pose_within_safety_limits(T_base_tcp),
            )
        )

    def has_ik_solution(self, T_base_tcp: Transform) -> bool:
        return bool(
            self._timed(
                "getInverseKinematicsHasSolution", lambda: self.arm.has_ik_solution(T_base_tcp)
            )
        )

    def move_linear(
        self,
        T_base_tcp: Transform,
        speed_mps: float,
        accel_mps2: float,
        timeout_s: float,
        on_progress: ProgressCallback | None = None,
    ) -> Transform:
        self.first_move_s = time.perf_counter()
        raise FirstMoveReached

    def stop_linear(self, decel_mps2: float) -> None:
        self.arm.stop_linear(decel_mps2)

    def set_digital_output(self, bank: OutputBank, index: int, value: bool) -> None:
        self.arm.set_digital_output(bank, index, value)

    def close(self) -> None:
        self.arm.close()


class TimedAudit(AuditLog):
    """The real audit log, each append timed into ``seconds``."""

    def __init__(self, path: Path, seconds: list[float]) -> None:
        super().__init__(path)
        self.seconds = seconds

    def append(self, record: Mapping[str, object]) -> None:
        start = time.perf_counter()
        super().append(record)
        self.seconds.append(time.perf_counter() - start)


def _stats_ms(values: list[float]) -> str:
    ms = sorted(v * 1000.0 for v in values)
    p90 = ms[min(len(ms) - 1, int(0.9 * len(ms)))]
    return f"median {statistics.median(ms):8.3f} ms   p90 {p90:8.3f} ms   (n={len(ms)})"


def _time_to_first_move(config: CellConfig, arm: URRtdeArm, runs: int) -> TimedArm:
    """Run the pick up to the first moveL ``runs`` times; the arm never moves."""
    detection = load_detection(DETECTION)
    hand_eye = config.hand_eye
    calibration = load_hand_eye(hand_eye.file, hand_eye.mode, hand_eye.units, hand_eye.invert)
    timed = TimedArm(arm)
    for _ in range(runs):
        audit = TimedAudit(config.audit.file, timed.seconds["audit append (fsync)"])
        start = time.perf_counter()  # detection and calibration in hand, session connected
        with contextlib.suppress(FirstMoveReached):
            run_pick(
                config,
                calibration,
                detection,
                timed,
                audit,
                dry_run=False,
                progress=Progress.quiet(),
            )
        if timed.first_move_s is None:
            raise RuntimeError("the pick ended before its first moveL")
        timed.seconds["TOTAL detection -> first moveL"].append(timed.first_move_s - start)
    return timed


def _compute_only(config: CellConfig, arm: URRtdeArm, runs: int) -> list[float]:
    """The pure part: chain, targets, workspace and tilt checks, from poses already read."""
    detection = load_detection(DETECTION)
    hand_eye = config.hand_eye
    calibration = load_hand_eye(hand_eye.file, hand_eye.mode, hand_eye.units, hand_eye.invert)
    T_base_flange = arm.flange_pose()
    T_flange_tcp = arm.tcp_offset()
    seconds = []
    for _ in range(runs):
        start = time.perf_counter()
        T_base_obj = calibration.T_base_cam(T_base_flange) @ detection.T_cam_obj
        targets = plan_targets(
            T_base_obj, T_base_flange @ T_flange_tcp, config.grasp, detection.position_only
        )
        for T in (targets.approach, targets.grasp, targets.retreat):
            workspace_problem(T, config.workspace)
            tilt_deg(T)
        seconds.append(time.perf_counter() - start)
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=50, help="picks measured (default 50)")
    parser.add_argument("--connections", type=int, default=5, help="new connections timed")
    args = parser.parse_args()
    config = load_config(CONFIG)
    with (
        tempfile.TemporaryDirectory() as folder,
        SimulatedController(host=HOST, tcp_offset=(0.0, 0.0, 0.12, 0.0, 0.0, 0.0), instant=True),
    ):
        config = dataclasses.replace(
            config,
            robot=dataclasses.replace(config.robot, host=HOST),
            audit=AuditConfig(file=Path(folder) / "picks.jsonl"),
        )
        connect_s = []
        for _ in range(args.connections):
            start = time.perf_counter()
            URRtdeArm(HOST).close()
            connect_s.append(time.perf_counter() - start)
        with URRtdeArm(HOST) as arm:
            pipe_s = []
            for _ in range(1000):
                start = time.perf_counter()
                arm._call("sample")  # one request/reply with the child, cached RTDE state only
                pipe_s.append(time.perf_counter() - start)
            compute_s = _compute_only(config, arm, args.runs * 20)
            timed = _time_to_first_move(config, arm, args.runs)

    print(f"pick latency against the simulated controller at {HOST} (500 Hz, instant motion)")
    rows = {
        "detection -> first moveL sent (connected)": timed.seconds.pop(
            "TOTAL detection -> first moveL"
        )
    }
    rows["compute alone (chain, targets, box, tilt)"] = compute_s
    for name, values in sorted(timed.seconds.items()):
        rows[f"  per call: {name}"] = values
    rows["pipe round trip to the ur_rtde child"] = pipe_s
    rows["new connection (connect + close)"] = connect_s
    width = max(len(name) for name in rows)
    for name, values in rows.items():
        print(f"{name:<{width}}  {_stats_ms(values)}")


if __name__ == "__main__":
    main()
