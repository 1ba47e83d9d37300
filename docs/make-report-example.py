"""Redraws docs/report-example.png, the picture of `handeye-pick report --plot` in docs/report.md.

A simulated 8-hour shift in a few minutes: a `Cell` runs capture, pick and place cycles against
the simulated UR controller (mocks/ur_controller, instant motion, on 127.0.0.249) through the real
ur_rtde client, with protective stops injected mid-grasp, an operator who unlocks them and
resumes after a few minutes, and now and then an empty bin (a candidate outside the workspace:
no candidate). The arm moves instantly, so the audit writer's clock is the shift's own: it is
set to the simulated time before every record (a cycle of 18 to 24 s, the operator's minutes),
and only that clock is simulated; every record is written by the real Cell.

Run it with the project's environment: .venv/bin/python docs/make-report-example.py [HOURS]
"""

from __future__ import annotations

import contextlib
import socket
import sys
import tempfile
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # mocks/ lives beside src/

from benchmarks.cycle import CELL_YAML as CYCLE_CELL  # noqa: E402
from benchmarks.cycle import OBJECT_BASE_M, TCP_OFFSET  # noqa: E402
from handeye_pick import Cell, audit  # noqa: E402
from handeye_pick.config.load import load_config  # noqa: E402
from handeye_pick.detection import detection_from_point_mm  # noqa: E402
from handeye_pick.errors import CellHalted, RobotFault  # noqa: E402
from handeye_pick.geometry import invert, transform_point  # noqa: E402
from handeye_pick.report.output import report_text  # noqa: E402
from handeye_pick.report.plot import render_report  # noqa: E402
from handeye_pick.report.shift import shift_report  # noqa: E402
from mocks.ur_controller import SimulatedController  # noqa: E402
from mocks.ur_controller.program import MOTION_KINDS  # noqa: E402

HOST = "127.0.0.249"
PICTURE = ROOT / "docs" / "report-example.png"
SHIFT_START = datetime(2026, 12, 2, 6, 0, tzinfo=timezone.utc)
SHIFT_S = float(sys.argv[1]) * 3600.0 if len(sys.argv) > 1 else 8 * 3600.0
FAR_AWAY_M = np.array([-0.52, -0.10, -0.50])  # below the table: every check refuses it
FAULT_HOURS = (1.3, 2.05, 4.6, 6.2, 6.4)  # protective stops, hours into the shift
STOOD_MIN = (4.0, 11.0, 6.0, 25.0, 3.0)  # how long the operator takes for each
EMPTY_BIN_EVERY = 37
# The cell of benchmarks/cycle.py, on this script's own address and audit file.
CELL_YAML = CYCLE_CELL.replace("127.0.0.250", HOST).replace("picks.jsonl", "shift.jsonl")


class ShiftClock:
    """The audit writer's clock: the simulated shift's time, moved on by the script."""

    seconds = 0.0

    @classmethod
    def now(cls, tz: object = None) -> datetime:
        cls.seconds += 0.2  # each record a little after the one before
        return SHIFT_START + timedelta(seconds=cls.seconds)


def _candidate(cell: Cell, T_base_flange: np.ndarray, where_m: np.ndarray) -> list[float]:
    p_cam = transform_point(invert(T_base_flange @ cell.calibration.T_cal), where_m)
    return [float(v) * 1000.0 for v in p_cam]


def _unlock_on_the_pendant() -> None:
    """What the operator does: unlock the protective stop (here through the dashboard)."""
    with socket.create_connection((HOST, 29999), timeout=5.0) as dashboard:
        reader = dashboard.makefile("r")
        reader.readline()  # the greeting
        dashboard.sendall(b"unlock protective stop\n")
        reader.readline()


def main() -> None:
    audit.datetime = ShiftClock  # type: ignore[misc]  # the one simulated thing: the clock
    rng = np.random.default_rng(20261202)
    faults = list(zip(FAULT_HOURS, STOOD_MIN, strict=True))
    with (
        tempfile.TemporaryDirectory() as folder,
        SimulatedController(
            host=HOST, tcp_offset=TCP_OFFSET, instant=True
        ) as ctl,
    ):
        config_path = Path(folder) / "cell.yaml"
        config_path.write_text(CELL_YAML)
        config = load_config(config_path)
        with Cell(config) as cell:
            cycle = 0
            while ShiftClock.seconds < SHIFT_S:
                cycle += 1
                fault = bool(faults) and ShiftClock.seconds > faults[0][0] * 3600.0
                if fault:  # halfway through the grasp, the second motion of the pick
                    moves = sum(1 for c in ctl.commands if c["kind"] in MOTION_KINDS.values())
                    ctl.inject(f"protective-stop@move:{moves + 2}:0.5")
                capture = cell.capture()
                assert capture.T_base_flange is not None
                empty = cycle % EMPTY_BIN_EVERY == 0
                where = FAR_AWAY_M if empty else OBJECT_BASE_M
                point = _candidate(cell, capture.T_base_flange, where)
                try:
                    cell.pick([detection_from_point_mm(point, "vision")], capture)
                except RobotFault:
                    with contextlib.suppress(CellHalted):  # the vision program asks again
                        cell.pick([detection_from_point_mm(point, "vision")], capture)
                    _, stood_min = faults.pop(0)
                    ShiftClock.seconds += stood_min * 60.0
                    _unlock_on_the_pendant()
                    cell.resume()
                except Exception:
                    if not empty:
                        raise
                ShiftClock.seconds += float(rng.uniform(18.0, 24.0))
        report = shift_report(config.audit.file, tz=timezone.utc)
        print(report_text(report))
        render_report(report, PICTURE)
        print(f"drawn to {PICTURE}")


if __name__ == "__main__":
    main()
