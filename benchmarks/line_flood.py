"""Does an OPC UA subscription flood cost the cell cycle time? And what does --opcua cost to start?

Usage: ``.venv/bin/python benchmarks/line_flood.py [--cycles 6] [--rounds 2] [--host 127.0.0.245]``

1. Start-up, each in a fresh process, interleaved (measure.py): ``python -c 'import numpy'``
   (the yardstick), ``handeye-pick run --help`` (no asyncua: it is imported only with
   ``--opcua``) and ``python -c 'import asyncua'`` (what ``--opcua`` adds to a run's start).
2. Cycle time: the simulated UR5e at real speed on ``--host`` and ``handeye-pick run --opcua``
   (config/loop.yaml's cell, picking a part at a known place), rounds of ``--cycles`` capture +
   pick + place cycles, alternately quiet and under a flood: a second process opens as many
   sessions as the server allows (and tries more), each with subscriptions to every variable at
   a 10 ms publishing interval, and counts the notifications. It prints the median cycle time
   of each kind side by side and their ratio; the goal is 1.0 (the server runs on its own
   thread and is bounded; the 2-core machine shares its cores with the flood's client).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from measure import ROOT, console_script, machine, print_table, side_by_side

sys.path.insert(0, str(ROOT))  # mocks/ is not installed with the package: import it from the clone

from handeye_pick.geometry import invert, transform_point, ur_pose_to_matrix
from handeye_pick.hand_eye.files import HandEyeMode, load_hand_eye
from mocks.ur_controller import SimulatedController

CONFIG = ROOT / "config" / "loop.yaml"
PART_BASE_M = np.array([-0.52, -0.10, 0.05])
PORT = 4842
NAMESPACE = "urn:handeye-pick:line"
FLOOD_SESSIONS = 10  # more than the server's MAX_SESSIONS (8): the extra ones are refused
SUBSCRIPTIONS_PER_SESSION = 4
YARDSTICK = "python -c 'import numpy'"


def startup(repeats: int) -> None:
    cli = console_script("handeye-pick")
    cases = {
        YARDSTICK: [sys.executable, "-c", "import numpy"],
        "handeye-pick run --help": [cli, "run", "--help"],
        "python -c 'import asyncua'": [sys.executable, "-c", "import asyncua"],
    }
    print(f"start-up: {repeats} interleaved runs of each, after one warm-up round")
    print_table(side_by_side(cases, repeats), YARDSTICK)


async def flood(url: str, stop_file: Path) -> None:
    """Every session the server takes, each subscribing to every variable at 10 ms, until
    ``stop_file`` exists; then the counts, one JSON line."""
    from asyncua.client.client import Client

    notifications = 0
    refused = 0

    class Count:
        def datachange_notification(self, node: Any, value: Any, data: Any) -> None:
            nonlocal notifications
            notifications += 1

    clients = []
    for _ in range(FLOOD_SESSIONS):
        client = Client(url, timeout=5)
        try:
            await client.connect()
        except Exception:
            refused += 1
            continue
        clients.append(client)
        ns = await client.get_namespace_index(NAMESPACE)
        machine_node = (await (await client.nodes.objects.get_child([f"{ns}:Machines"]))
                        .get_children())[0]
        line = await machine_node.get_child([f"{ns}:Line"])
        counters = await line.get_child([f"{ns}:Counters"])
        variables = [*(await line.get_variables()), *(await counters.get_variables())]
        for _ in range(SUBSCRIPTIONS_PER_SESSION):
            try:
                subscription = await client.create_subscription(10, Count())
                await subscription.subscribe_data_change(variables, sampling_interval=0)
            except Exception:
                refused += 1
    while not stop_file.exists():
        await asyncio.sleep(0.1)
    for client in clients:
        with contextlib.suppress(Exception):  # a session the server ended is gone already
            await client.disconnect()
    print(json.dumps({"sessions": len(clients), "refused": refused,
                      "notifications": notifications}))


class Cell:
    """``handeye-pick run --opcua`` through a pipe, picking the part at PART_BASE_M."""

    def __init__(self, host: str, folder: Path) -> None:
        data = yaml.safe_load(CONFIG.read_text())
        data["robot"]["host"] = host
        data["hand_eye"]["file"] = str((CONFIG.parent / data["hand_eye"]["file"]).resolve())
        data["audit"]["file"] = str(folder / "picks.jsonl")
        config = folder / "cell.yaml"
        config.write_text(yaml.safe_dump(data, sort_keys=False))
        self.T_flange_cam = load_hand_eye(CONFIG.parent / "loop" / "hand_eye.yaml",
                                          HandEyeMode.EYE_IN_HAND, "mm").T_cal
        self.process = subprocess.Popen(
            [console_script("handeye-pick"), "run", "--config", str(config), "--opcua",
             f"{host}:{PORT}", "--quiet"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
        )

    def ask(self, request: dict[str, Any]) -> dict[str, Any]:
        assert self.process.stdin is not None
        assert self.process.stdout is not None
        self.process.stdin.write(json.dumps(request) + "\n")
        self.process.stdin.flush()
        reply: dict[str, Any] = json.loads(self.process.stdout.readline())
        return reply

    def cycle(self, n: int) -> float:
        """One capture + pick + place; its wall time (s)."""
        started = time.perf_counter()
        captured = self.ask({"id": f"c{n}", "op": "capture"})
        T_base_cam = ur_pose_to_matrix(captured["flange_pose_ur"]) @ self.T_flange_cam
        point_mm = transform_point(invert(T_base_cam), PART_BASE_M) * 1000.0
        reply = self.ask({"id": f"p{n}", "op": "pick", "capture_id": captured["capture_id"],
                          "candidates": [{"position_mm": point_mm.tolist()}]})
        if reply.get("status") != "placed":
            raise SystemExit(f"pick {n}: {reply}")
        return time.perf_counter() - started

    def close(self) -> None:
        self.ask({"id": "q", "op": "quit"})
        self.process.wait(timeout=30)


def cycles(args: argparse.Namespace) -> None:
    folder = ROOT / "out" / "line_flood"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "picks.jsonl").unlink(missing_ok=True)
    times: dict[str, list[float]] = {"quiet": [], "flood": []}
    floods: list[dict[str, int]] = []
    with SimulatedController(host=args.host, tcp_offset=[0, 0, 0.12, 0, 0, 0],
                             log_path=folder / "simulator.log"):
        cell = Cell(args.host, folder)
        cell.ask({"id": "home", "op": "move", "pose": "home"})
        cell.cycle(0)  # warm-up
        n = 0
        for _ in range(args.rounds):
            for kind in ("quiet", "flood"):
                flooder = None
                stop_file = folder / "flood.stop"
                stop_file.unlink(missing_ok=True)
                if kind == "flood":
                    flooder = subprocess.Popen(
                        [sys.executable, __file__, "--flood", f"opc.tcp://{args.host}:{PORT}",
                         "--stop-file", str(stop_file)],
                        stdout=subprocess.PIPE, text=True,
                    )
                    time.sleep(3.0)  # its sessions and subscriptions are up
                for _ in range(args.cycles):
                    n += 1
                    times[kind].append(cell.cycle(n))
                if flooder is not None:
                    stop_file.touch()
                    out, _ = flooder.communicate(timeout=60)
                    if out.strip():
                        floods.append(json.loads(out.strip().splitlines()[-1]))
        cell.close()
    quiet, flooded = statistics.median(times["quiet"]), statistics.median(times["flood"])
    print(f"\ncycle time, {len(times['quiet'])} cycles each, interleaved in rounds of "
          f"{args.cycles} (capture + pick + place, real speed):")
    print(f"  quiet:  median {quiet:.3f} s  (min {min(times['quiet']):.3f}, "
          f"max {max(times['quiet']):.3f})")
    print(f"  flood:  median {flooded:.3f} s  (min {min(times['flood']):.3f}, "
          f"max {max(times['flood']):.3f})")
    print(f"  flood / quiet: {flooded / quiet:.3f}")
    print(f"  flood clients: {floods or 'ended before reporting'}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=6)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=5, help="start-up runs of each")
    parser.add_argument("--host", default="127.0.0.245")
    parser.add_argument("--flood", metavar="URL", help=argparse.SUPPRESS)
    parser.add_argument("--stop-file", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.flood:
        import logging

        logging.basicConfig(level=logging.CRITICAL)  # a dropped session's noise is expected
        asyncio.run(flood(args.flood, args.stop_file))
        return
    print(machine())
    startup(args.repeats)
    cycles(args)


if __name__ == "__main__":
    main()
