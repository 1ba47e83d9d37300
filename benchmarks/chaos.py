"""A chaos soak: ``handeye-pick run`` through a pipe for many cycles while every fault the simulator
can inject, a killed controller and a SIGKILLed ``run`` strike at seeded random moments.

Starts the simulated controller (``python -m mocks.ur_controller``, instant motion, a Robotiq
gripper with a 40 mm part) as its own process on ``--host`` (default 127.0.0.247), so killing it
is a real SIGKILL and restarting it a new process, and ``handeye-pick run`` on a cell with a place
pose. Each cycle is a capture and a pick that places. Before a cycle, with probability
``--fault-rate``, one event is armed, its kind the next of a shuffled deck of every kind (KINDS;
a new deck once all are dealt, so every kind comes as soon as there were as many events): a
fault injected through the admin port at a random moment of the coming pick
(``FAULT@move:K:FRACTION``, K a random move of the pick, FRACTION 0.05..0.95), the part taken
away (a missed grasp), or a timer that SIGKILLs the controller or ``run`` a random fraction of a
typical cycle after the capture is sent.

After the cycle, as an operator and a supervisor would: a ``run`` that was killed is restarted
(it must take the one-session-per-robot lock again, its orphaned ur_rtde child must exit); a
halting reply (fault, dropped, aborted) must be followed by a move request answered ``halted``;
the cause is cleared from what the pendant shows (dashboard unlock, restart safety / power on /
brake release, close safety popup, remote control on, the part back, the gripper reset or its
fingers opened) or by restarting the controller (it was killed, the gripper went silent, or the
pick ended before the armed fault's move, which would strike a later cycle: "not fired"); the
controller's command record must show no motion command since the fault; then ``resume`` is sent
until it answers ``ready`` (bounded attempts). A missed grasp leaves the cell ready: no resume.

At the end it checks the audit file whole (every line parses, every plan has exactly one
outcome, an ``abandoned`` one only for a pick whose ``run`` was killed) and prints per kind how
many were injected and how each ended, each invariant with PASS or FAIL, cycles per hour and the
figures of every ``run`` process and its ur_rtde child. Exit 0 when every invariant holds, 1
otherwise, 3 when the controller cannot listen on the address. Every wait is bounded.

Run: ``.venv/bin/python benchmarks/chaos.py [--cycles 2000] [--seed 1] [--fault-rate 0.05]
[--host 127.0.0.247] [--folder DIR]``; tests/integration/test_chaos_short.py runs a short one.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import random
import select
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter, defaultdict
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # mocks/ lives beside src/

from benchmarks.cycle import CELL_YAML, CLI, OBJECT_BASE_M, TCP_OFFSET  # noqa: E402
from benchmarks.run_pipe import (  # noqa: E402
    Pipe,
    RunEnded,
    dashboard,
    figures,
    workers,
)
from handeye_pick.geometry import invert, transform_point, ur_pose_to_matrix  # noqa: E402
from handeye_pick.hand_eye.files import HandEyeMode, load_hand_eye  # noqa: E402
from mocks.ur_controller import admin  # noqa: E402

HOST = "127.0.0.247"  # its own address: leaves the tests' and the other benchmarks' alone
PART_MM = 40.0
ROBOTIQ_PORT = 63352
MOTION_KINDS = {"moveL", "moveJ", "moveL_FK", "moveJ_IK"}
PICK_MOVES = 6  # approach, grasp, retreat, place approach, place, place retreat
HALTING = {"fault", "dropped", "aborted"}  # endings that halt the session (docs/requests.md)
RESUME_ATTEMPTS = 20
RESUME_PAUSE_S = 0.5
START_TIMEOUT_S = 30.0
ORPHAN_EXIT_S = 10.0  # a killed run's ur_rtde child leaves at its pipe's end of file
WARMUP_CYCLES = 10  # placed cycles of one run process before its early figures are taken
FLAT_MIN_CYCLES = 50  # a run process judged for flatness placed at least this many cycles
RSS_GROWTH_LIMIT_KIB = 4096
EXIT_BROKEN, EXIT_CANNOT_LISTEN = 1, 3
SAFETY_PROTECTIVE, SAFETY_SAFEGUARD, SAFETY_EMERGENCY = 3, 5, 7
ROBOT_RUNNING = 7

ROBOTIQ = (
    "  gripper:\n    type: robotiq-2f\n    expected_width_mm: [38, 42]\n"
    "    speed_pct: 100\n    force_pct: 40\n    timeout_s: 0.5\n"
)


@dataclass(frozen=True)
class Kind:
    """One kind of event. ``spec``: the simulator's fault, fired during move ``moves[0]`` ..
    ``moves[1]`` of the coming pick (1 approach .. 6 place retreat); ``kill``: "controller" or
    "run", SIGKILLed by a timer; ``restart_controller``: the operator's only way to clear it."""

    spec: str | None = None
    moves: tuple[int, int] = (1, PICK_MOVES)
    kill: str | None = None
    restart_controller: bool = False


KINDS: dict[str, Kind] = {
    "protective-stop": Kind("protective-stop"),
    "emergency-stop": Kind("emergency-stop"),
    "safeguard-stop": Kind("safeguard-stop"),
    "program-stopped": Kind("stop-program"),
    "dropped-link": Kind("drop-connection"),
    "frozen-stream": Kind("stall:3"),  # ur_rtde gives a stream up after 2.5 s
    # refuse-move refuses the motion command after the one it fires in: K+1 stays in the pick.
    "refused-move": Kind("refuse-move", moves=(1, PICK_MOVES - 1)),
    "remote-control-off": Kind("remote-control-off"),
    "dropped-part": Kind("gripper-drop", moves=(3, 5)),  # the part is held from 3 to 5
    "gripper-fault": Kind("gripper-fault:14", moves=(1, 5)),  # 0x0E overcurrent
    "gripper-silent": Kind("gripper-silent", moves=(1, 5), restart_controller=True),
    "missed-grasp": Kind(),  # the part is taken away before the pick
    "refused-start": Kind(),  # the RTDE start of the next resume is refused
    "controller-killed": Kind(kill="controller", restart_controller=True),
    "run-killed": Kind(kill="run"),
}


class Broken(Exception):
    """An invariant broke in a way the soak cannot go on from (a hang, a resume that never
    comes back)."""


class Controller:
    """The simulated controller as its own process, killable and restartable; each start writes
    its command record to a new file."""

    def __init__(self, host: str, folder: Path) -> None:
        self.host = host
        self.folder = folder
        self.starts = 0
        self.process: subprocess.Popen[bytes] | None = None
        self.record: Path = folder / "commands-0.jsonl"
        self.motion_record: Path = folder / "motions-0.jsonl"

    def start(self) -> None:
        """Start a new controller process; OSError when it cannot listen on the address."""
        self.starts += 1
        self.record = self.folder / f"commands-{self.starts}.jsonl"
        self.motion_record = self.folder / f"motions-{self.starts}.jsonl"
        argv = [sys.executable, "-m", "mocks.ur_controller", "--host", self.host, "--instant",
                "--tcp-offset", *(repr(v) for v in TCP_OFFSET), "--part-width-mm", repr(PART_MM),
                "--record", str(self.record), "--record-motions", str(self.motion_record),
                "--log-level", "WARNING"]
        with (self.folder / f"controller-{self.starts}.log").open("wb") as log:
            self.process = subprocess.Popen(argv, cwd=ROOT, stdin=subprocess.DEVNULL,
                                            stdout=subprocess.PIPE, stderr=log)
        assert self.process.stdout is not None
        ready, _, _ = select.select([self.process.stdout], [], [], START_TIMEOUT_S)
        line = self.process.stdout.readline() if ready else b""
        if not line.startswith(b"ready"):
            self.kill()
            raise OSError(f"the simulated controller did not start on {self.host} "
                          f"(see {self.folder}/controller-{self.starts}.log)")

    def kill(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.kill()
        if self.process is not None:
            self.process.wait(timeout=10)
            assert self.process.stdout is not None
            self.process.stdout.close()

    @property
    def alive(self) -> bool:
        return self.process is not None and self.process.poll() is None

    def admin(self, message: dict[str, Any]) -> Any:
        return admin.request(self.host, message)

    def motions(self) -> int:
        """Motion commands this controller process has run (its command record; a refused one
        ran nothing and is not counted by ``move:K`` either)."""
        if not self.record.exists():
            return 0
        entries = [json.loads(line) for line in self.record.read_text().splitlines()]
        return sum(1 for e in entries if e["kind"] in MOTION_KINDS and not e.get("refused"))

    def last_motion_end(self) -> str:
        """How the latest ended motion of this controller process ended (its motion record)."""
        lines = self.motion_record.read_text().splitlines() if self.motion_record.exists() else []
        return json.loads(lines[-1])["end"] if lines else "no motion"


@dataclass
class RunProcess:
    """One ``handeye-pick run`` process and what was measured of it."""

    pipe: Pipe
    number: int
    placed: int = 0
    early: dict[str, dict[str, int]] | None = None  # after WARMUP_CYCLES placed cycles
    late: dict[str, dict[str, int]] | None = None  # the last sample
    most_children: int = 0
    early_fds: list[str] = field(default_factory=list)  # what the descriptors are, early
    late_fds: list[str] = field(default_factory=list)


@dataclass
class Soak:
    """The state of one chaos soak and what it found."""

    host: str
    folder: Path
    rng: random.Random
    controller: Controller
    config: Path
    T_flange_cam: np.ndarray
    ids: Iterator[int] = field(default_factory=lambda: itertools.count(1))
    runs: list[RunProcess] = field(default_factory=list)
    injected: Counter[str] = field(default_factory=Counter)
    endings: dict[str, Counter[str]] = field(default_factory=lambda: defaultdict(Counter))
    failures: list[str] = field(default_factory=list)
    checks: Counter[str] = field(default_factory=Counter)
    lost: set[str] = field(default_factory=set)  # request ids in flight when run was killed
    ops: dict[str, str] = field(default_factory=dict)  # request id -> op, of every request sent
    replied: Counter[str] = field(default_factory=Counter)  # request id -> replies
    cycle_s: list[float] = field(default_factory=list)  # wall time of placed cycles
    last_pick: dict[str, Any] = field(default_factory=dict)  # the latest pick request
    deck: list[str] = field(default_factory=list)  # the kinds still to come in this round
    armed_at: int | None = None  # the controller's move index of a fault armed for this cycle
    elapsed_s: float = 0.0  # wall time of the cycles
    flat_lines: list[str] = field(default_factory=list)  # the figures of each run process

    def next_kind(self) -> str:
        """The next kind from a shuffled deck of every kind, so that a short soak meets each
        kind as soon as it has had as many events as there are kinds."""
        if not self.deck:
            self.deck = sorted(KINDS)
            self.rng.shuffle(self.deck)
        return self.deck.pop()

    # --- run ---------------------------------------------------------------------------------

    @property
    def run(self) -> RunProcess:
        return self.runs[-1]

    def start_run(self) -> None:
        number = len(self.runs) + 1
        with (self.folder / f"run-{number}.log").open("wb") as log:
            process = subprocess.Popen(
                [*CLI, "run", "--config", str(self.config), "--quiet"],
                cwd=self.folder, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=log,
            )
        self.runs.append(RunProcess(Pipe(process, self.ids), number))

    def ask(self, request: dict[str, Any]) -> dict[str, Any]:
        """One request to the current run; RunEnded when run died before its reply."""
        pipe = self.run.pipe
        try:
            rid = pipe.send(request)
        except BrokenPipeError:
            raise RunEnded("run's input is closed") from None
        self.ops[rid] = request["op"]
        try:
            reply = pipe.reply()
        except RunEnded:
            self.lost.add(rid)
            raise
        except TimeoutError as exc:
            raise Broken(f"request {rid} {request['op']}: {exc} (a hang)") from None
        self.replied[str(reply.get("id"))] += 1
        if str(reply.get("id")) != rid:
            self.fail(f"request {rid} answered by a reply for {reply.get('id')}")
        return reply

    def sample(self) -> None:
        """Figures of the run process and its child after a placed cycle."""
        run = self.run
        run.placed += 1
        pid = run.pipe.process.pid
        sample = figures(pid)
        run.most_children = max(run.most_children, len(workers(pid)))
        if run.placed == WARMUP_CYCLES:
            run.early, run.early_fds = sample, _descriptors(pid)
        run.late, run.late_fds = sample, _descriptors(pid)

    def restart_run(self) -> None:
        """After a SIGKILL: reap it, restart it at once as a supervisor would, check its orphaned
        ur_rtde child leaves and the new one takes the cell (a status request answered)."""
        old = self.run.pipe.process
        orphans = workers(old.pid) if old.poll() is None else []
        old.wait(timeout=10)
        for stream in (old.stdin, old.stdout):
            if stream is not None:
                stream.close()
        for attempt in (1, 2):  # a supervisor restarts again after a failed start
            self.start_run()
            try:
                reply = self.ask({"op": "status"})
            except RunEnded as exc:
                log = (self.folder / f"run-{self.run.number}.log").read_text().strip()
                self.check("a restarted run takes the cell", False, f"{exc}: {log[-300:]}")
                if attempt == 2:
                    raise Broken("run does not start again after a SIGKILL") from None
                time.sleep(2.0)
                continue
            self.check("a restarted run takes the cell", reply.get("ok") is True,
                       f"status {reply}")
            break
        deadline = time.monotonic() + ORPHAN_EXIT_S
        while orphans and time.monotonic() < deadline:
            orphans = [pid for pid in orphans if Path(f"/proc/{pid}").exists()
                       and _state(pid) != "Z"]
            time.sleep(0.05)
        self.check("a killed run's ur_rtde child exits", not orphans, f"still running: {orphans}")

    # --- one cycle ---------------------------------------------------------------------------

    def cycle(self) -> str:
        """Capture and pick: the ending (the first reply's status that is not a success)."""
        started = time.monotonic()
        captured = self.ask({"op": "capture"})
        if not captured.get("ok"):
            return f"capture {captured['status']}"
        T_base_flange = ur_pose_to_matrix(captured["flange_pose_ur"])
        p_cam = transform_point(invert(T_base_flange @ self.T_flange_cam), OBJECT_BASE_M)
        request = {"op": "pick", "capture_id": captured["capture_id"],
                   "candidates": [{"position_mm": (np.asarray(p_cam) * 1e3).tolist()}]}
        reply = self.ask(request)
        self.last_pick = request
        if reply["status"] == "placed":
            self.cycle_s.append(time.monotonic() - started)
        return str(reply["status"])

    def typical_cycle_s(self) -> float:
        recent = self.cycle_s[-50:]
        return statistics.median(recent) if recent else 0.2

    def arm(self, name: str, move: int, fraction: float, delay: float) -> threading.Timer | None:
        """Arm the event ``name`` for the coming cycle; a kill's timer, started."""
        kind = KINDS[name]
        self.armed_at = None
        if kind.spec is not None:
            self.armed_at = self.controller.motions() + move
            spec = f"{kind.spec}@move:{self.armed_at}:{fraction}"
            self.controller.admin({"op": "inject", "spec": spec})
        elif name == "missed-grasp":
            self.controller.admin({"op": "set_part", "width_mm": None})
        if kind.kill is None:
            return None
        target = (self.controller.process if kind.kill == "controller"
                  else self.run.pipe.process)
        assert target is not None
        timer = threading.Timer(delay * self.typical_cycle_s(), target.send_signal,
                                (signal.SIGKILL,))
        timer.start()
        return timer

    # --- recovery ----------------------------------------------------------------------------

    def unfired(self) -> bool:
        """A fault armed for this cycle that has not fired (the pick ended before its move):
        it would strike a later cycle, so only a new controller process clears it."""
        armed_at, self.armed_at = self.armed_at, None
        return (armed_at is not None and self.controller.alive
                and self.controller.motions() < armed_at)

    def recover(self, name: str | None, ending: str, unfired: bool = False) -> None:
        """What an operator (and a supervisor) does after the event ``name`` ended in
        ``ending``; checks nothing moved between the ending and the resume. ``unfired``: the
        event's fault is still armed in the controller."""
        if ending == "no reply" or self.run.pipe.process.poll() is not None:
            self.restart_run()
        motions = self.controller.motions() if self.controller.alive else None
        if ending.split()[-1] in HALTING:
            blocked = self.ask(self.last_pick)
            self.check("a halted session answers a motion request halted",
                       blocked["status"] == "halted", f"after {ending}: {blocked}")
        kind = KINDS[name] if name is not None else Kind()
        if not self.controller.alive or kind.restart_controller or unfired:
            self.controller.kill()
            self.controller.start()
            motions = None  # a new controller process has run nothing yet
        self.clear()
        if name == "missed-grasp" and ending == "missed":
            return  # a missed grasp leaves the cell ready
        if name == "run-killed":
            return  # a fresh session: nothing to resume
        now = self.controller.motions()
        self.check("no motion commanded after a fault before its resume",
                   now == (motions or 0), f"{name} ended {ending}: {motions} -> {now}")
        if name == "refused-start":
            self.controller.admin({"op": "inject", "spec": "refuse-start"})
        self.resume(name)

    def clear(self) -> None:
        """Clear what the pendant and the gripper show, as an operator would."""
        state = self.controller.admin({"op": "snapshot"})
        if not state["remote_control"]:  # first: in local control the dashboard is refused
            self.controller.admin({"op": "set_remote_control", "enabled": True})
        safety = state["safety_mode"]
        commands = {SAFETY_PROTECTIVE: ["unlock protective stop"],
                    SAFETY_SAFEGUARD: ["close safety popup"],
                    SAFETY_EMERGENCY: ["restart safety"]}.get(safety, [])
        if safety == SAFETY_EMERGENCY or state["robot_mode"] != ROBOT_RUNNING:
            commands += ["power on", "brake release"]
        if commands:
            dashboard(self.host, *commands)
        if not state["part_present"]:
            self.controller.admin({"op": "set_part", "width_mm": PART_MM})
        if _gripper(self.host, "GET FLT") not in ("FLT 0", None):
            _gripper(self.host, "SET ACT 0")  # reset: the session activates it, fingers open
        elif _gripper(self.host, "GET POS") not in ("POS 0", None):
            _gripper(self.host, "SET POS 0 GTO 1")  # fingers left closed: open from the pendant

    def resume(self, name: str | None) -> None:
        first: str | None = None
        for _ in range(RESUME_ATTEMPTS):
            reply = self.ask({"op": "resume"})
            first = first or str(reply["status"])
            if reply["status"] == "ready":
                if name == "refused-start":
                    self.endings[name][f"resume {first}"] += 1
                return
            time.sleep(RESUME_PAUSE_S)
        raise Broken(f"resume after {name} not ready after {RESUME_ATTEMPTS} attempts: {reply}")

    # --- bookkeeping -------------------------------------------------------------------------

    def check(self, invariant: str, passed: bool, detail: str) -> None:
        self.checks[invariant] += 1
        if not passed:
            self.fail(f"{invariant}: {detail}")

    def fail(self, message: str) -> None:
        self.failures.append(message)
        print(f"BROKEN: {message}", flush=True)


def _state(pid: int) -> str:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("State:"):
                return line.split()[1]
    except OSError:
        pass
    return "gone"


def _descriptors(pid: int) -> list[str]:
    """What each open descriptor of ``pid`` refers to (socket:[inode] names no peer)."""
    found = []
    for fd in sorted(Path(f"/proc/{pid}/fd").iterdir(), key=lambda p: int(p.name)):
        try:
            found.append(f"{fd.name}:{os.readlink(fd)}")
        except OSError:
            continue
    return found


def _gripper(host: str, request: str) -> str | None:
    """One request on the Robotiq socket; None when the gripper does not answer."""
    try:
        with socket.create_connection((host, ROBOTIQ_PORT), timeout=1.0) as sock:
            sock.sendall(request.encode() + b"\n")
            return sock.makefile("r").readline().strip()
    except OSError:
        return None


def soak(soak_state: Soak, cycles: int, fault_rate: float) -> None:
    """Run the cycles."""
    s = soak_state
    for number in range(1, cycles + 1):
        # Every draw is made whatever happens after it, so a seed gives the same events.
        strike = s.rng.random() < fault_rate
        move = s.rng.randint(1, PICK_MOVES)
        fraction = round(s.rng.uniform(0.05, 0.95), 2)
        delay = s.rng.random()
        event = s.next_kind() if strike else None
        timer = None
        if event is not None:
            s.injected[event] += 1
            kind = KINDS[event]
            low, high = kind.moves
            timer = s.arm(event, low + (move - 1) % (high - low + 1), fraction, delay)
        try:
            ending = s.cycle()
        except RunEnded:
            ending = "no reply"
        if timer is not None:
            timer.join()  # the kill was sent, perhaps after the cycle ended: wait for its end
            by_controller = KINDS[event].kill == "controller"
            killed = s.controller.process if by_controller else s.run.pipe.process
            assert killed is not None
            killed.wait(timeout=10)
        unfired = s.unfired()
        if event is None and ending == "placed":
            s.sample()
            continue
        s.endings[event or "(none)"][ending + (" (not fired)" if unfired else "")] += 1
        if event is None:
            s.fail(f"cycle {number} without an injected event ended {ending} (the controller's "
                   f"last motion: {s.controller.last_motion_end()})")
        s.recover(event, ending, unfired)
        with (s.folder / "events.jsonl").open("a") as log:  # for a person reading after a FAIL
            log.write(json.dumps({"cycle": number, "event": event, "move": move,
                                  "fraction": fraction, "delay": delay, "ending": ending,
                                  "last_request": len(s.ops),
                                  "run_fds": len(_descriptors(s.run.pipe.process.pid))}) + "\n")


def audit_check(s: Soak) -> None:
    """The audit file parses whole; every plan has one outcome; abandoned only for a killed
    pick; every pick request that got a reply has one outcome record."""
    lines = (s.folder / "picks.jsonl").read_text().splitlines()
    records, torn = [], 0
    for line in lines:
        try:
            records.append(json.loads(line))
        except ValueError:
            torn += 1
    s.check("the audit file parses whole", torn == 0, f"{torn} lines are not JSON")
    outcomes: Counter[str] = Counter()
    requests: Counter[str] = Counter()
    abandoned = set()
    plans = {}
    for record in records:
        if record.get("event") == "plan":
            plans[record["pick_id"]] = record
        elif record.get("event") == "outcome":
            outcomes[record["pick_id"]] += 1
            if record.get("status") == "abandoned":
                abandoned.add(record["pick_id"])
            elif record.get("request_id") is not None:
                requests[str(record["request_id"])] += 1
    for pick_id, plan in plans.items():
        s.check("every plan has one outcome, or an abandoned record after a kill",
                outcomes[pick_id] == 1, f"plan {pick_id} has {outcomes[pick_id]} outcomes")
        if pick_id in abandoned:
            s.check("an abandoned record only for a pick whose run was killed",
                    str(plan.get("request_id")) in s.lost, f"plan {pick_id} {plan}")
    for rid, op in s.ops.items():
        if op == "pick" and rid not in s.lost:
            s.check("every pick request has one outcome record", requests[rid] == 1,
                    f"request {rid} ({op}) has {requests[rid]} outcome records")
    s.checks["(abandoned records)"] = len(abandoned)
    s.checks["(plans)"] = len(plans)


def reply_check(s: Soak) -> None:
    for rid in s.ops:
        expected = 0 if rid in s.lost else 1
        s.check("every request got exactly one reply", s.replied[rid] == expected,
                f"request {rid} got {s.replied[rid]} replies")


def flat_check(s: Soak) -> list[str]:
    """Each run process that placed FLAT_MIN_CYCLES cycles, and the ur_rtde child it had, from
    its early figures to its last: RSS within RSS_GROWTH_LIMIT_KIB, descriptors and threads
    not more, never more than one ur_rtde child. Returns the lines to print."""
    lines = []
    for run in s.runs:
        if run.early is None or run.late is None:
            lines.append(f"  run #{run.number}: {run.placed} placed cycles, no figures after "
                         "warm-up")
            continue
        judged = run.placed >= FLAT_MIN_CYCLES
        for name in run.early:
            first, last = run.early[name], run.late.get(name, run.early[name])
            growth = last["rss_kib"] - first["rss_kib"]
            flat = (growth <= RSS_GROWTH_LIMIT_KIB and last["fds"] <= first["fds"]
                    and last["threads"] <= first["threads"])
            lines.append(
                f"  run #{run.number} {name:<14} {run.placed:5d} cycles  RSS "
                f"{first['rss_kib'] / 1024:6.1f} -> {last['rss_kib'] / 1024:6.1f} MiB  fds "
                f"{first['fds']} -> {last['fds']}  threads {first['threads']} -> "
                f"{last['threads']}" + ("" if judged else "  (too short to judge)"))
            if judged:
                new = sorted(set(run.late_fds) - set(run.early_fds)) if name == "run" else []
                s.check("memory, descriptors and threads of run and its child stay flat", flat,
                        lines[-1].strip() + (f" (new in run: {new})" if new else ""))
        s.check("memory, descriptors and threads of run and its child stay flat",
                run.most_children <= 1, f"run #{run.number} had {run.most_children} children")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--fault-rate", type=float, default=0.05,
                        help="probability that an event strikes a cycle (default 0.05)")
    parser.add_argument("--host", default=HOST,
                        help=f"loopback address of the controller (default {HOST})")
    parser.add_argument("--folder", type=Path, help="keep the audit file, records and logs here")
    args = parser.parse_args(argv)
    # SIGTERM ends the soak as Ctrl-C does: through the finally that kills what it started.
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.folder or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        try:
            s = chaos_soak(folder, args.host, args.cycles, args.seed, args.fault_rate)
        except OSError as exc:
            print(f"chaos: {exc}")
            return EXIT_CANNOT_LISTEN
    report(s, args)
    return EXIT_BROKEN if s.failures else 0


def chaos_soak(folder: Path, host: str, cycles: int, seed: int, fault_rate: float) -> Soak:
    """The whole soak in ``folder`` with the controller on ``host``, every invariant checked
    (``Soak.failures`` lists what broke); OSError when the controller cannot listen there."""
    config = folder / "cell.yaml"
    config.write_text(CELL_YAML.replace("127.0.0.250", host)
                      .replace("robot:\n", "robot:\n" + ROBOTIQ, 1))
    T_flange_cam = load_hand_eye(ROOT / "config" / "demo" / "hand_eye.yaml",
                                 HandEyeMode.EYE_IN_HAND, "mm").T_cal
    controller = Controller(host, folder)
    controller.start()
    s = Soak(host, folder, random.Random(seed), controller, config, T_flange_cam)
    try:
        s.start_run()
        started = time.monotonic()
        try:
            soak(s, cycles, fault_rate)
        except Broken as exc:
            s.fail(str(exc))
        s.elapsed_s = time.monotonic() - started
        if s.run.pipe.process.poll() is None:
            bye = s.ask({"op": "quit"})
            extra = s.run.pipe.process.stdout.read() if s.run.pipe.process.stdout else b""
            s.check("every request got exactly one reply", bye["status"] == "bye" and not extra,
                    f"quit answered {bye}, then {extra[:200]!r}")
            s.run.pipe.process.wait(timeout=30)
    finally:
        for run in s.runs:
            if run.pipe.process.poll() is None:
                run.pipe.process.kill()
                run.pipe.process.wait()
        controller.kill()
    audit_check(s)
    reply_check(s)
    s.flat_lines = flat_check(s)
    return s


def report(s: Soak, args: argparse.Namespace) -> None:
    elapsed_s = s.elapsed_s
    print(f"chaos soak: {args.cycles} cycles in {elapsed_s:.0f} s through `handeye-pick run`, "
          f"seed {args.seed}, fault rate {args.fault_rate} (simulated controller at {args.host}, "
          "instant motion)")
    if elapsed_s > 0:
        print(f"  cycles per hour: {args.cycles / elapsed_s * 3600:.0f}")
    print(f"  {'event':<20} {'injected':>8}  endings")
    for name in [*sorted(KINDS), "(none)"]:
        endings = s.endings.get(name, Counter())
        injected = s.injected[name] if name in KINDS else sum(endings.values())
        if injected or name != "(none)":
            text = ", ".join(f"{ending} {n}" for ending, n in sorted(endings.items()) if n)
            print(f"  {name:<20} {injected:8d}  {text}")
    print(f"  run processes: {len(s.runs)}, controller processes: {s.controller.starts}, "
          f"plans: {s.checks['(plans)']}, abandoned: {s.checks['(abandoned records)']}, "
          f"requests: {len(s.ops)}, lost to a SIGKILL of run: {len(s.lost)}")
    print("  invariants:")
    failed = {message.split(":")[0] for message in s.failures}
    for invariant, count in sorted(s.checks.items()):
        if not invariant.startswith("("):
            verdict = "FAIL" if invariant in failed else "PASS"
            print(f"    {verdict} {invariant} ({count} checks)")
    for message in s.failures:
        if message.split(":")[0] not in s.checks:
            print(f"    FAIL {message}")
    print(f"  figures per run process, early (after {WARMUP_CYCLES} placed cycles) -> last; flat "
          f"= RSS grew at most {RSS_GROWTH_LIMIT_KIB // 1024} MiB, descriptors and threads did "
          f"not grow, at most one ur_rtde child (judged from {FLAT_MIN_CYCLES} placed cycles):")
    for line in s.flat_lines:
        print(line)
    print(f"  result: {'FAIL' if s.failures else 'PASS'} ({len(s.failures)} broken)")


if __name__ == "__main__":
    sys.exit(main())
