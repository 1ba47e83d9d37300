"""A complete pick against the simulated UR controller, in about ten seconds.

Starts ``python -m mocks.ur_controller`` on 127.0.0.1 (a UR5e at its home pose with the demo's
120 mm TCP), waits for it to listen, runs

    handeye-pick pick --config config/demo.yaml --detection config/demo/detection.yaml

which prints its progress, the plan and the result, then stops the controller, also on a failure
or Ctrl-C, and prints the total wall time and the share of it the arm spent moving (from the
simulated controller's motion record). The controller's log goes to
out/simulated_pick-simulator.log under the current folder. Exits with the pick's status (0 done,
2 input, 3 refused, 4 fault, 130 interrupted), or 1 with one line when the controller cannot
start (another one already serves 127.0.0.1).
Needs only ``pip install -e .``; run it from anywhere.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import IO

ROOT = Path(__file__).resolve().parents[1]
HOST = "127.0.0.1"
SIMULATOR_LOG = Path("out") / "simulated_pick-simulator.log"  # under the current folder
EXIT_INTERRUPTED = 130
READY_TIMEOUT_S = 20.0
CONTROLLER = [
    sys.executable,
    "-m",
    "mocks.ur_controller",
    "--host",
    HOST,
    "--tcp-offset",
    "0",
    "0",
    "0.12",
    "0",
    "0",
    "0",  # as robot.tcp_offset in config/demo.yaml
    "--speed-factor",
    "2",  # twice real time: fast, and still slow enough to follow
]
PICK_ARGS = ["pick", "--config", "config/demo.yaml", "--detection", "config/demo/detection.yaml"]
# The installed console script may not be on PATH (venv not activated): call its function.
PICK = [sys.executable, "-c", "import sys; from handeye_pick.cli import main; sys.exit(main())"]


def _watch(stream: IO[str], ready: threading.Event) -> None:
    """Flag the controller's ``ready`` line (its only other output goes to its log)."""
    for line in stream:
        if line.startswith("ready"):
            ready.set()


def _wait_ready(controller: subprocess.Popen[str]) -> bool:
    ready = threading.Event()
    if controller.stdout is not None:
        threading.Thread(target=_watch, args=(controller.stdout, ready), daemon=True).start()
    deadline = time.monotonic() + READY_TIMEOUT_S
    while not ready.wait(0.1):
        if controller.poll() is not None:
            print(
                f"error: the simulated controller exited ({controller.returncode}) before it was "
                f"ready: is another one already serving {HOST}? stop it, then run this again "
                f"({SIMULATOR_LOG} says why)",
                file=sys.stderr,
            )
            return False
        if time.monotonic() > deadline:
            print(
                f"error: the simulated controller was not ready within {READY_TIMEOUT_S:.0f} s "
                f"({SIMULATOR_LOG} says why)",
                file=sys.stderr,
            )
            return False
    return True


def _run_pick() -> int:
    print(f"$ handeye-pick {' '.join(PICK_ARGS)}", flush=True)
    pick = subprocess.Popen(PICK + PICK_ARGS, cwd=ROOT)
    try:
        return pick.wait()
    except KeyboardInterrupt:
        # The pick got the same Ctrl-C: let it send stopL and write its audit record.
        return pick.wait(timeout=30.0)


def main() -> int:
    try:
        return _demo()
    except KeyboardInterrupt:  # before the pick started
        print("interrupted (Ctrl-C) before the pick; the simulated controller is stopped",
              file=sys.stderr)
        return EXIT_INTERRUPTED


def _demo() -> int:
    started = time.monotonic()
    SIMULATOR_LOG.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as folder, SIMULATOR_LOG.open("w") as log:
        motions = Path(folder) / "motions.jsonl"
        controller_args = [*CONTROLLER, "--record-motions", str(motions)]
        print(f"$ python {' '.join(controller_args[1:])}", flush=True)
        print(f"(the simulated controller's log goes to {SIMULATOR_LOG})", flush=True)
        # Its own session: a Ctrl-C at the terminal must reach the pick (which then sends stopL),
        # not the simulated robot, which is stopped below once the pick has ended.
        controller = subprocess.Popen(
            controller_args,
            cwd=ROOT,
            stdout=subprocess.PIPE,
            stderr=log,
            text=True,
            start_new_session=True,
        )
        try:
            if not _wait_ready(controller):
                return 1
            status = _run_pick()
        finally:
            controller.terminate()
            try:
                controller.wait(timeout=10.0)
            except subprocess.TimeoutExpired:
                controller.kill()
                controller.wait()
        lines = motions.read_text().splitlines() if motions.exists() else []
    moving_s = sum(json.loads(line)["moving_s"] for line in lines)
    total_s = time.monotonic() - started
    print(
        f"demo: {total_s:.1f} s in all, of which the arm moved {moving_s:.1f} s "
        f"({moving_s / total_s:.0%}; motion runs 2 x real speed)",
        flush=True,
    )
    return status


if __name__ == "__main__":
    sys.exit(main())
