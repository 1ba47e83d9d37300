"""The cell in the line: an operator panel over OPC UA and a PLC wired to the controller's I/O,
while a vision program picks (docs/line.md).

Starts the simulated UR5e controller on --host (default 127.0.0.1), then

    handeye-pick run --config out/line_panel/cell.yaml --opcua HOST:4841

where the cell config is config/loop.yaml with the wired handshake added (``line.io``: cycle
stop on DI4, stop on DI5, resume on DI6; ready, executing, held, halted and heartbeat on DO4,
DO5, DO6, DO7 and DO3). Three actors then play the line:

- the vision program (a pipe to ``run``) waits for the conveyor to bring a part (1.5 s),
  captures, picks it at a known place on the table and places it, for ``--picks`` cycles; a
  request answered ``held`` is asked again once the cell no longer holds;
- the panel, an OPC UA client, prints the cell's state and counters once a second;
- the PLC, through the simulator's admin port (what its wires would do): after three parts
  have arrived it raises DI4 (cycle stop), waits for the cell's held output, keeps the cell
  held for two seconds and drops DI4 again (release).

Exits 0 when the cell held after its third pick and before its fourth, every pick placed, and
the panel's counters say so; 1 otherwise. Run it after ``pip install -e .``:
python examples/line_panel.py
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # mocks/ is not installed with the package: import it from the clone

from asyncua.client.client import Client  # noqa: E402

from handeye_pick.geometry import invert, transform_point, ur_pose_to_matrix  # noqa: E402
from handeye_pick.hand_eye.files import HandEyeMode, load_hand_eye  # noqa: E402
from mocks.ur_controller import SimulatedController  # noqa: E402

CONFIG = ROOT / "config" / "loop.yaml"
OUT = Path("out") / "line_panel"
PORT = 4841
PART_BASE_M = np.array([-0.52, -0.10, 0.05])  # where each part lies on the table (base frame)
CYCLE_STOP, HELD_OUTPUT = 4, 6  # the PLC's wires: DI4 in, DO6 out
HOLD_AFTER, HOLD_S = 3, 2.0
FEED_S = 1.5  # the conveyor brings the next part this long after a pick
LINE_IO = {
    "io": {
        "inputs": {"cycle_stop": CYCLE_STOP, "stop": 5, "resume": 6},
        "outputs": {"ready": 4, "executing": 5, "held": HELD_OUTPUT, "halted": 7, "heartbeat": 3},
    }
}
NAMESPACE = "urn:handeye-pick:line"
# The installed console script may not be on PATH (venv not activated): call its function.
HANDEYE_PICK = [sys.executable, "-c",
                "import sys; from handeye_pick.cli import main; sys.exit(main())"]


def write_config(host: str) -> Path:
    """config/loop.yaml on ``host`` with the wired handshake, its files made absolute."""
    data = yaml.safe_load(CONFIG.read_text())
    data["robot"]["host"] = host
    data["hand_eye"]["file"] = str((CONFIG.parent / data["hand_eye"]["file"]).resolve())
    data["audit"]["file"] = str((OUT / "picks.jsonl").resolve())
    data["line"] = LINE_IO
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "picks.jsonl").unlink(missing_ok=True)
    path = OUT / "cell.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


class Vision:
    """The vision program: one JSON request at a time through ``run``'s pipe."""

    def __init__(self, process: subprocess.Popen[str]) -> None:
        self.process = process
        calibration = load_hand_eye(CONFIG.parent / "loop" / "hand_eye.yaml",
                                    HandEyeMode.EYE_IN_HAND, "mm")
        self.T_flange_cam = calibration.T_cal
        self.held_in: list[int] = []  # the cycles in which a request was answered held
        self.cycle_number = 0

    def ask(self, request: dict[str, Any]) -> dict[str, Any]:
        """The reply, asked again (after the hold) while the cell answers ``held``."""
        assert self.process.stdin is not None
        assert self.process.stdout is not None
        while True:
            self.process.stdin.write(json.dumps(request) + "\n")
            self.process.stdin.flush()
            reply: dict[str, Any] = json.loads(self.process.stdout.readline())
            if reply.get("status") != "held":
                return reply
            self.held_in.append(self.cycle_number)
            print(f"vision: {request['op']} answered held (by {reply['held_by']}); waiting")
            while self.ask({"id": "s", "op": "status"}).get("held"):
                time.sleep(0.2)

    def cycle(self, n: int) -> dict[str, Any]:
        self.cycle_number = n
        time.sleep(FEED_S)
        captured = self.ask({"id": f"c{n}", "op": "capture"})
        T_base_cam = ur_pose_to_matrix(captured["flange_pose_ur"]) @ self.T_flange_cam
        point_mm = transform_point(invert(T_base_cam), PART_BASE_M) * 1000.0
        return self.ask({"id": f"p{n}", "op": "pick", "capture_id": captured["capture_id"],
                         "candidates": [{"position_mm": point_mm.tolist()}]})


async def panel(url: str, stop: threading.Event, seen: dict[str, Any]) -> None:
    """The operator panel: state and counters once a second (read five times a second, so the
    PLC below, which looks at what the panel read, counts parts as they arrive)."""
    async with Client(url) as client:
        ns = await client.get_namespace_index(NAMESPACE)
        machine = (await (await client.nodes.objects.get_child([f"{ns}:Machines"]))
                   .get_children())[0]
        state = await machine.get_child([f"{ns}:MachineryBuildingBlocks",
                                         f"{ns}:MachineryItemState", f"{ns}:CurrentState"])
        line = await machine.get_child([f"{ns}:Line"])
        names = ("Held", "Heartbeat", "LastErrorCode", "Counters/Placed", "Counters/Cycles",
                 "Counters/CycleTimeMedian", "Counters/HeldSeconds")
        nodes = {name: await line.get_child([f"{ns}:{p}" for p in name.split("/")])
                 for name in names}
        looks = 0
        while not stop.is_set():
            values = {name: await node.read_value() for name, node in nodes.items()}
            seen.update(values)
            looks += 1
            if looks % 5:
                await asyncio.sleep(0.2)
                continue
            median = values["Counters/CycleTimeMedian"]
            print(f"panel: {(await state.read_value()).Text:12s} held={values['Held']!s:5s} "
                  f"placed={values['Counters/Placed']} cycles={values['Counters/Cycles']} "
                  f"median={median:.2f}s held_for={values['Counters/HeldSeconds']:.1f}s "
                  f"error={values['LastErrorCode']} heartbeat={values['Heartbeat']}")
            await asyncio.sleep(0.2)


def plc(ctl: SimulatedController, seen: dict[str, Any], stop: threading.Event,
        log: list[str]) -> None:
    """The PLC: after three parts, a cycle stop on DI4 until the cell has held for 2 s."""
    while not stop.is_set() and seen.get("Counters/Placed", 0) < HOLD_AFTER:
        time.sleep(0.1)
    if stop.is_set():
        return
    print(f"plc: {HOLD_AFTER} parts arrived: DI{CYCLE_STOP} high (cycle stop)")
    ctl.set_inputs({CYCLE_STOP: True})
    while not stop.is_set() and not ctl.snapshot().standard_digital_out >> HELD_OUTPUT & 1:
        time.sleep(0.05)
    log.append(f"held after {seen.get('Counters/Placed')} picks")
    print(f"plc: DO{HELD_OUTPUT} (held) is on; releasing in {HOLD_S:g} s")
    stop.wait(HOLD_S)
    ctl.set_inputs({CYCLE_STOP: False})
    print(f"plc: DI{CYCLE_STOP} low (release)")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--host", default="127.0.0.1", help="loopback address of the simulator")
    parser.add_argument("--picks", type=int, default=5)
    args = parser.parse_args()
    # The panel's client outlives the server when run ends; asyncua would log that it cannot
    # close a session on a closed connection.
    logging.getLogger("asyncua").setLevel(logging.ERROR)
    config = write_config(args.host)
    url = f"opc.tcp://{args.host}:{PORT}"
    with SimulatedController(host=args.host, tcp_offset=[0, 0, 0.12, 0, 0, 0],
                             speed_factor=4.0, log_path=OUT / "simulator.log") as ctl:
        process = subprocess.Popen(
            [*HANDEYE_PICK, "run", "--config", str(config), "--opcua", f"{args.host}:{PORT}"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
        )
        stop = threading.Event()
        seen: dict[str, Any] = {}
        plc_log: list[str] = []
        vision = Vision(process)
        try:
            vision.ask({"id": "home", "op": "move", "pose": "home"})  # run is up: OPC UA too
            threads = [
                threading.Thread(target=lambda: asyncio.run(panel(url, stop, seen))),
                threading.Thread(target=plc, args=(ctl, seen, stop, plc_log)),
            ]
            for thread in threads:
                thread.start()
            statuses = []
            for n in range(1, args.picks + 1):
                reply = vision.cycle(n)
                statuses.append(reply["status"])
                print(f"vision: pick {n}: {reply['status']}")
            time.sleep(1.5)  # one more look of the panel after the last pick
            vision.ask({"id": "q", "op": "quit"})
        finally:
            stop.set()
            if process.stdin is not None:
                process.stdin.close()
            process.wait(timeout=30)
        for thread in threads:
            thread.join()
    ok = (statuses == ["placed"] * args.picks
          and set(vision.held_in) == {HOLD_AFTER + 1}  # the fourth cycle waited for the release
          and seen.get("Counters/Placed") == args.picks)
    print("line panel example:", "every check passed" if ok
          else f"FAILED: picks {statuses}, held in cycles {vision.held_in}, plc {plc_log}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
