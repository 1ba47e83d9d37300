"""A long session: ``handeye-pick run`` through a pipe for many cycles, with faults and resumes.

Starts the simulated controller on 127.0.0.251 (instant motion: the session's own costs dominate,
as in a long shift they accumulate) and ``handeye-pick run`` on a cell with a place pose, then
runs capture/pick/place cycles. Every ``--fault-every`` cycles it injects a protective stop into
the next pick's grasp move, checks that the pick is answered ``fault`` and that the next pick is
answered ``halted`` (nothing moves before resume), unlocks the stop as an operator would
(dashboard) and sends ``resume``.

Prints cycles per hour, resident memory, open file descriptors and threads of the run process
and of its ur_rtde child at the start and the end, and whether every pick request has its plan
and its outcome in the audit file. Run: ``.venv/bin/python benchmarks/soak.py [--cycles 1000]``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # mocks/ lives beside src/

from benchmarks.cycle import CELL_YAML, CLI, OBJECT_BASE_M, TCP_OFFSET  # noqa: E402
from benchmarks.run_pipe import Pipe, dashboard, figures, print_figures  # noqa: E402
from handeye_pick.geometry import invert, transform_point, ur_pose_to_matrix  # noqa: E402
from handeye_pick.hand_eye.files import HandEyeMode, load_hand_eye  # noqa: E402
from mocks.ur_controller import SimulatedController  # noqa: E402

HOST = "127.0.0.251"
MOTION_KINDS = {"moveL", "moveJ", "moveL_FK", "moveJ_IK"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=1000)
    parser.add_argument("--fault-every", type=int, default=100)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp, SimulatedController(
        host=HOST, tcp_offset=TCP_OFFSET, instant=True
    ) as ctl:
        folder = Path(tmp)
        config = folder / "cell.yaml"
        config.write_text(CELL_YAML.replace("127.0.0.250", HOST))
        T_flange_cam = load_hand_eye(
            ROOT / "config" / "demo" / "hand_eye.yaml", HandEyeMode.EYE_IN_HAND, "mm"
        ).T_cal
        run = subprocess.Popen(
            [*CLI, "run", "--config", str(config), "--quiet"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
        )
        pipe = Pipe(run)
        picks: dict[str, str] = {}  # request id -> reply status
        faults = halted_ok = 0
        start_figures: dict[str, dict[str, int]] = {}
        started = time.monotonic()
        for cycle in range(1, args.cycles + 1):
            inject = cycle % args.fault_every == 0
            if inject:  # the grasp is the 2nd motion of the next pick
                moves = sum(1 for c in ctl.commands if c["kind"] in MOTION_KINDS)
                ctl.inject(f"protective-stop@move:{moves + 2}:0.5")
            captured = pipe.ask({"op": "capture"})
            T_base_flange = ur_pose_to_matrix(captured["flange_pose_ur"])
            p_cam = transform_point(invert(T_base_flange @ T_flange_cam), OBJECT_BASE_M)
            candidate = {"position_mm": (np.asarray(p_cam) * 1000.0).tolist()}
            request = {"op": "pick", "capture_id": captured["capture_id"],
                       "candidates": [candidate]}
            reply = pipe.ask(request)
            picks[reply["id"]] = reply["status"]
            if inject:
                faults += reply["status"] == "fault"
                blocked = pipe.ask(request)
                picks[blocked["id"]] = blocked["status"]
                halted_ok += blocked["status"] == "halted"
                dashboard(HOST, "unlock protective stop")
                if pipe.ask({"op": "resume"})["status"] != "ready":
                    raise RuntimeError("resume failed")
            elif reply["status"] != "placed":
                raise RuntimeError(f"cycle {cycle}: {reply}")
            if cycle == 1:
                start_figures = figures(run.pid)
        elapsed_s = time.monotonic() - started
        end_figures = figures(run.pid)
        pipe.ask({"op": "quit"})
        run.wait(timeout=30)
        records = [json.loads(line) for line in (folder / "picks.jsonl").read_text().splitlines()]

    events: dict[str, set[str]] = {}
    for record in records:
        if record.get("request_id") in picks:
            events.setdefault(record["request_id"], set()).add(record["event"])
    moved = [rid for rid, status in picks.items() if status in ("placed", "fault")]
    accounted = all(events.get(rid, set()) >= {"plan", "outcome"} for rid in moved)
    refused_audited = all("outcome" in events.get(rid, set()) for rid in picks)
    print(f"soak: {args.cycles} cycles in {elapsed_s:.0f} s through `handeye-pick run` "
          f"(simulated controller at {HOST}, instant motion)")
    print(f"  cycles per hour: {args.cycles / elapsed_s * 3600:.0f}")
    print(f"  faults injected: {args.cycles // args.fault_every}, answered fault: {faults}, "
          f"next pick answered halted: {halted_ok}, resumed: {faults}")
    print_figures(start_figures, end_figures)
    print(f"  every pick that moved has plan and outcome on disk: {accounted} ({len(moved)} picks)")
    print(f"  every pick request has an outcome record: {refused_audited} ({len(picks)} requests)")


if __name__ == "__main__":
    main()
