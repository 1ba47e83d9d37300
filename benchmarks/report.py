"""How long does ``handeye-pick report`` take on a million-record audit file, and how much memory?

Usage: ``.venv/bin/python benchmarks/report.py [--records 1000000] [--repeats 3]``

Writes a temporary audit file of ``--records`` records shaped as ``handeye-pick run`` writes a
shift (per cycle: the move to the capture pose, its outcome, the capture, the pick's plan with
its matrices, targets and checks, and its outcome with the reached poses and their errors; some
6.5 kB of plan), every 500th cycle a protective stop, a pick refused while halted and a resume,
every 97th a pick with no candidate, and a torn last line. The records are written by
``AuditLog`` once as templates and copied with new times and pick ids. Then it runs the command
(``--json`` to /dev/null, and with ``--plot``) through ``measure.run_once``: wall time from spawn
to exit and peak RSS, the figures to compare with the requirement (under 10 s, memory flat: the
same peak for a tenth of the records).
"""

from __future__ import annotations

import argparse
import json
import tempfile
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np
from measure import console_script, machine, run_once

from handeye_pick.audit import AuditLog

CYCLE_S = 3.2  # a cycle every 3.2 s, a little jitter
FAULT_EVERY = 500
NO_CANDIDATE_EVERY = 97
STOOD_S = 240.0  # how long each protective stop makes the cell stand
POSE = [-0.45, -0.133, 0.6, 3.1416, 0.0, 0.0]
STEPS = ("approach", "grasp", "retreat", "place_approach", "place", "place_retreat")


def _templates(folder: Path) -> dict[str, str]:
    """One line of each record kind, written by the real AuditLog, with placeholders."""
    path = folder / "templates.jsonl"
    log = AuditLog(path, pick_id="PICKID")
    matrix = np.eye(4) + 0.123456789
    checks = [
        {"name": f"{kind}_{step}", "target": step, "passed": True, "detail": "within 0.0 of 1.0"}
        for step in STEPS
        for kind in ("workspace", "tilt", "safety_limits", "inverse_kinematics")
    ]
    common = {"cycle": 1, "request_id": "REQ"}
    shapes: dict[str, dict[str, object]] = {
        "move_plan": {
            "event": "plan",
            **common,
            "pose": "capture",
            "operation": "move capture",
            "config": "/cell/cell.yaml",
            "host": "10.0.0.5",
            "targets": {"capture": [0.0, -1.63, 1.34, -1.28, -1.57, 0.0]},
            "checks": checks[:3],
        },
        "move_outcome": {
            "event": "outcome",
            **common,
            "pose": "capture",
            "operation": "move capture",
            "reached": {"capture": POSE},
            "status": "done",
        },
        "capture": {
            "event": "capture",
            **common,
            "capture_id": "c1",
            "flange_pose_source": "latched",
            "flange_pose": POSE,
        },
        "pick_plan": {
            "event": "plan",
            **common,
            "capture_id": "c1",
            "dry_run": False,
            "candidate": 0,
            "config": "/cell/cell.yaml",
            "host": "10.0.0.5",
            "detection": {"source": "vision", "position_only": False, "T_cam_obj": matrix},
            "calibration": {
                "file": "/cell/hand_eye.yaml",
                "sha256": "0" * 64,
                "mode": "eye-in-hand",
                "units": "mm",
                "inverted": False,
            },
            "tcp_offset": [0.0, 0.0, 0.12, 0.0, 0.0, 0.0],
            "flange_pose": POSE,
            "flange_pose_source": "latched",
            "T_base_cam": matrix,
            "T_base_obj": matrix,
            "motion": {"speed_mps": 0.25, "grasp_speed_mps": 0.05, "accel_mps2": 1.2},
            "place_index": 0,
            "targets": {step: [p + 0.000123456 for p in POSE] for step in STEPS},
            "checks": checks,
        },
        "pick_outcome": {
            "event": "outcome",
            **common,
            "dry_run": False,
            "capture_id": "c1",
            "reached": {step: [p + 0.000123456 for p in POSE] for step in STEPS},
            "gripper": {"kind": "robotiq", "commands": [{"command": "close"}, {"command": "open"}]},
            "status": "placed",
            "candidate": 0,
            "errors": {step: {"position_mm": 0.0123, "rotation_deg": 0.0045} for step in STEPS},
        },
        "fault": {
            "event": "outcome",
            **common,
            "dry_run": False,
            "capture_id": "c1",
            "step": "grasp",
            "reached": {"approach": POSE},
            "stop": "stopL sent",
            "status": "fault",
            "error": {
                "type": "RobotFault",
                "message": "moveL to grasp: protective stop",
                "safety_mode": 3,
                "runtime_state": 2,
                "robot_mode": 7,
            },
        },
        "no_candidate": {
            "event": "outcome",
            **common,
            "dry_run": False,
            "status": "refused",
            "error": {"type": "NoFeasibleCandidate", "message": "no candidate passed"},
        },
        "halted": {
            "event": "outcome",
            **common,
            "dry_run": False,
            "status": "halted",
            "error": {"type": "CellHalted", "message": "cell halted: resume"},
        },
        "resume": {
            "event": "resume",
            "request_id": "REQ",
            "status": "ready",
            "halted": "RobotFault: moveL to grasp: protective stop",
            "problems": [],
        },
    }
    for shape in shapes.values():
        log.append(shape)
    lines = path.read_text().splitlines()
    path.unlink()
    return {
        name: line.replace(json.loads(line)["timestamp"], "{time}").replace("PICKID", "{pick}")
        for name, line in zip(shapes, lines, strict=True)
    }


def _cycle(n: int) -> list[str]:
    """The names of the records of cycle ``n``, in order."""
    names = ["move_plan", "move_outcome", "capture"]
    if n % FAULT_EVERY == FAULT_EVERY - 1:
        return [*names, "pick_plan", "fault", "halted", "resume"]
    if n % NO_CANDIDATE_EVERY == NO_CANDIDATE_EVERY - 1:
        return [*names, "no_candidate"]
    return [*names, "pick_plan", "pick_outcome"]


def write_audit(path: Path, records: int) -> int:
    """Write about ``records`` records to ``path``; return how many were written."""
    templates = _templates(path.parent)
    start = datetime(2026, 12, 2, 6, 0, tzinfo=timezone.utc)
    rng = np.random.default_rng(7)
    written, n, t = 0, 0, 0.0
    with path.open("w") as file:
        while written < records:
            for index, name in enumerate(_cycle(n)):
                moment = start + timedelta(seconds=t + 0.4 * index)
                time = moment.isoformat(timespec="microseconds")
                pick = f"{n:016x}{index:016x}"
                file.write(templates[name].replace("{time}", time).replace("{pick}", pick) + "\n")
                written += 1
                if name == "fault":
                    t += STOOD_S
            t += CYCLE_S + float(rng.uniform(-0.3, 0.3))
            n += 1
        file.write(templates["pick_plan"][:700])  # a writer killed mid-line: a torn last line
    return written


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=1_000_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    command = console_script("handeye-pick")
    print(machine())
    with tempfile.TemporaryDirectory() as folder:
        for records in (args.records // 10, args.records):
            path = Path(folder) / f"audit-{records}.jsonl"
            written = write_audit(path, records)
            size_mb = path.stat().st_size / 1e6
            print(f"audit file: {written} records and a torn line, {size_mb:.0f} MB")
            for label, extra in (("--json", ["--json"]), ("--plot", ["--plot", f"{path}.png"])):
                runs = [
                    run_once([command, "report", str(path), *extra]) for _ in range(args.repeats)
                ]
                seconds = sorted(run.seconds for run in runs)
                peak = max(run.peak_mib for run in runs)
                print(
                    f"  report {label:<7} median {seconds[len(seconds) // 2]:6.2f} s  "
                    f"min {seconds[0]:6.2f}  max {seconds[-1]:6.2f}  peak RSS {peak:6.1f} MiB"
                )
            path.unlink()


if __name__ == "__main__":
    main()
